// 32-bit values in pairs of 16-bit Modbus registers, in the register map's
// word order. Shared by the master (modbus_rig.h), the emulator's server and
// the tests, so that both ends agree by construction.
#ifndef KCRIG_IO_DRIVERS_MODBUS_REGISTERS_H_
#define KCRIG_IO_DRIVERS_MODBUS_REGISTERS_H_

#include <bit>
#include <cstdint>

namespace kcrig {

inline void PutUint32(std::uint32_t value, bool high_word_first,
                      std::uint16_t* registers) {
  const auto high = static_cast<std::uint16_t>(value >> 16);
  const auto low = static_cast<std::uint16_t>(value & 0xffffu);
  registers[0] = high_word_first ? high : low;
  registers[1] = high_word_first ? low : high;
}

inline std::uint32_t GetUint32(const std::uint16_t* registers,
                               bool high_word_first) {
  const std::uint32_t first = registers[0], second = registers[1];
  return high_word_first ? (first << 16) | second : (second << 16) | first;
}

// IEEE 754 binary32.
inline void PutFloat32(double value, bool high_word_first,
                       std::uint16_t* registers) {
  PutUint32(std::bit_cast<std::uint32_t>(static_cast<float>(value)),
            high_word_first, registers);
}

inline double GetFloat32(const std::uint16_t* registers, bool high_word_first) {
  return std::bit_cast<float>(GetUint32(registers, high_word_first));
}

}  // namespace kcrig

#endif  // KCRIG_IO_DRIVERS_MODBUS_REGISTERS_H_
