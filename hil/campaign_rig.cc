#include "hil/campaign_rig.h"

#include <filesystem>
#include <memory>

#include "hil/rig_factory.h"
#include "hil/rig_session.h"

namespace kcrig {

Status CampaignRig::Open(const std::string& uri, const KcrigConfig& config,
                         CampaignRig* rig) {
  rig->uri_ = uri;
  rig->config_ = config;
  KCRIG_RETURN_IF_ERROR(LoadRigConfig(config.directory, &rig->rig_config_));
  std::unique_ptr<RigInterface> probe;
  KCRIG_RETURN_IF_ERROR(MakeRig(uri, rig->rig_config_, "", &probe));
  KCRIG_RETURN_IF_ERROR(probe->Configure());
  probe.reset();
  RigSessionOptions check;
  check.excitation =
      config.experiment.Excitation(0.0, config.experiment.z_a_bounds.lower);
  return ValidateRunRequest(rig->rig_config_, check);
}

Status CampaignRig::Run(const RampExcitation<double>& excitation, int run,
                        const std::string& csv_path,
                        const std::atomic<int>* stop) const {
  namespace fs = std::filesystem;
  if (fs::path(csv_path).filename() != "run.csv") {
    return Status::Error(csv_path + ": a rig run writes run.csv");
  }
  if (stop->load() != 0) {
    return Status::Error("interrupted by a signal before run " +
                         std::to_string(run));
  }
  const std::string log_dir = fs::path(csv_path).parent_path().string();
  std::unique_ptr<RigInterface> transport;
  KCRIG_RETURN_IF_ERROR(MakeRig(uri_, rig_config_, log_dir, &transport));
  KCRIG_RETURN_IF_ERROR(transport->Configure());
  RigSessionOptions options;
  options.excitation = excitation;
  options.log_dir = log_dir;
  options.stop_signal = stop;
  RigSessionResult result;
  KCRIG_RETURN_IF_ERROR(
      RunRigSession(config_, rig_config_, transport.get(), options, &result));
  if (!result.completed) {
    return Status::Error("run " + std::to_string(run) + " on " + uri_ + " " +
                         result.trip_message + " (log in " + log_dir + ")");
  }
  return Status::Ok();
}

}  // namespace kcrig
