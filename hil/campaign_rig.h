// The campaign's runs on a rig behind a transport (modbus-tcp://,
// modbus-rtu://, can:): one rig session per run, into the run's folder.
#ifndef KCRIG_HIL_CAMPAIGN_RIG_H_
#define KCRIG_HIL_CAMPAIGN_RIG_H_

#include <atomic>
#include <string>

#include "base/status.h"
#include "hil/rig_config.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

class CampaignRig {
 public:
  // Checks the URI, the register map or DBC, the rig itself (Configure)
  // and the campaign's excitations at their limits (phi 0, the lowest z_a,
  // the config's Fmax and tf) before any output exists.
  static Status Open(const std::string& uri, const KcrigConfig& config,
                     CampaignRig* rig);

  // Runs `excitation` as run number `run`; the log is `csv_path`, which
  // must be a run.csv (its
  // folder also takes can.log and timing.json). A trip is an error.
  // `stop` (the SIGINT/SIGTERM flag) ends the run with a ramp-down and
  // refuses it once set.
  Status Run(const RampExcitation<double>& excitation, int run,
             const std::string& csv_path, const std::atomic<int>* stop) const;

 private:
  std::string uri_;
  KcrigConfig config_;
  RigConfig rig_config_;
};

}  // namespace kcrig

#endif  // KCRIG_HIL_CAMPAIGN_RIG_H_
