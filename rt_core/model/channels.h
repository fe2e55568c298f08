// The six measured channels (ISO 8855 rig frame: wheel-centre x, y, z [m]
// and toe, camber, caster [rad]), their names and how engineers read them
// (mm and deg).
#ifndef KCRIG_RT_CORE_MODEL_CHANNELS_H_
#define KCRIG_RT_CORE_MODEL_CHANNELS_H_

#include <numbers>

namespace kcrig {

inline constexpr double kDegree = std::numbers::pi / 180.0;  // [rad]

inline constexpr int kNumChannels = 6;
inline constexpr const char* kChannelNames[kNumChannels] = {
    "x", "y", "z", "toe", "camber", "caster"};

// A channel's value as engineers read it (mm for x, y, z; deg for the
// angles) from SI (m, rad), and that unit.
inline double ChannelDisplayValue(int channel, double si) {
  return channel < 3 ? si * 1e3 : si / kDegree;
}
inline const char* ChannelDisplayUnit(int channel) {
  return channel < 3 ? "mm" : "deg";
}

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_CHANNELS_H_
