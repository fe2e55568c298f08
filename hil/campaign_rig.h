// The campaign's runs on a rig: one rig session per run, into the run's
// folder. The rig is behind a transport (modbus-tcp://, modbus-rtu://,
// can:) or in-process (the software-in-the-loop rig, on its virtual clock).
#ifndef KCRIG_HIL_CAMPAIGN_RIG_H_
#define KCRIG_HIL_CAMPAIGN_RIG_H_

#include <atomic>
#include <functional>
#include <memory>
#include <string>

#include "base/status.h"
#include "hil/rig_config.h"
#include "hil/rig_session.h"
#include "records/run_log.h"
#include "rt_core/model/model_config.h"
#include "rt_core/runtime/clock.h"
#include "rt_core/runtime/rig_interface.h"

namespace kcrig {

// Makes the link to the rig for one run, not configured; a record the link
// keeps (a CAN run's bus log) goes to `log_dir`.
using RigConnector = std::function<Status(const std::string& log_dir,
                                          std::unique_ptr<RigInterface>*)>;

class CampaignRig {
 public:
  // A rig behind a transport. Checks the URI, the register map or DBC, the
  // rig itself (Configure) and the campaign's excitations at their limits
  // (phi 0, the lowest z_a, the config's Fmax and tf) before any output
  // exists.
  static Status Open(const std::string& uri, const KcrigConfig& config,
                     CampaignRig* rig);

  // A rig in-process, described as `name`, whose links `connect` makes,
  // run on `clock` (which must outlive the rig); `truth` goes to every
  // log's sidecar. The same checks.
  static Status Open(const std::string& name, RigConnector connect,
                     Clock* clock, const RunMetadata& truth,
                     const KcrigConfig& config, CampaignRig* rig);

  // Runs `excitation` as run number `run`; the log is `csv_path`, which
  // must be a run.csv (its folder also takes can.log and timing.json). A
  // trip is an error. `stop` (the SIGINT/SIGTERM flag) ends the run with a
  // ramp-down and refuses it once set. `monitor` (optional) watches the
  // run live.
  Status Run(const RampExcitation<double>& excitation, int run,
             const std::string& csv_path, const std::atomic<int>* stop,
             RunMonitor* monitor = nullptr) const;

 private:
  // The rest of Open, rig_config_ loaded.
  Status Init(const std::string& name, RigConnector connect, Clock* clock,
              const RunMetadata& truth, const KcrigConfig& config);
  Status Check() const;

  std::string name_;
  RigConnector connect_;
  Clock* clock_ = nullptr;
  std::shared_ptr<const RunMetadata> truth_;
  KcrigConfig config_;
  RigConfig rig_config_;
};

}  // namespace kcrig

#endif  // KCRIG_HIL_CAMPAIGN_RIG_H_
