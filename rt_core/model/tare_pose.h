// A rig log's tare as a plant starts from it (BasicRigPlant::SettleAtRest).
#ifndef KCRIG_RT_CORE_MODEL_TARE_POSE_H_
#define KCRIG_RT_CORE_MODEL_TARE_POSE_H_

#include "rt_core/model/rotation.h"

namespace kcrig {

// What the sensors read at rest, the tare rows' mean, and at the log's first
// row (a structure still creeping from the last run moves during the tare):
// x, y, z [m], toe, camber, caster [rad].
struct TarePose {
  Vec6<double> mean = Vec6<double>::Zero();
  Vec6<double> at_start = Vec6<double>::Zero();
};

}  // namespace kcrig

#endif  // KCRIG_RT_CORE_MODEL_TARE_POSE_H_
