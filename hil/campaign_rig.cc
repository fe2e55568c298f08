#include "hil/campaign_rig.h"

#include <filesystem>
#include <utility>

#include "hil/rig_factory.h"
#include "hil/rig_session.h"

namespace kcrig {

Status CampaignRig::Open(const std::string& uri, const KcrigConfig& config,
                         CampaignRig* rig) {
  KCRIG_RETURN_IF_ERROR(LoadRigConfig(config.directory, &rig->rig_config_));
  RigConnector connect = [uri, rig_config = rig->rig_config_](
                             const std::string& log_dir,
                             std::unique_ptr<RigInterface>* link) {
    return MakeRig(uri, rig_config, log_dir, link);
  };
  return rig->Init(uri, std::move(connect), nullptr, RunMetadata(), config);
}

Status CampaignRig::Open(const std::string& name, RigConnector connect,
                         Clock* clock, const RunMetadata& truth,
                         const KcrigConfig& config, CampaignRig* rig) {
  KCRIG_RETURN_IF_ERROR(LoadRigConfig(config.directory, &rig->rig_config_));
  return rig->Init(name, std::move(connect), clock, truth, config);
}

Status CampaignRig::Init(const std::string& name, RigConnector connect,
                         Clock* clock, const RunMetadata& truth,
                         const KcrigConfig& config) {
  name_ = name;
  connect_ = std::move(connect);
  clock_ = clock;
  if (!truth.truth_parameters.empty()) {
    truth_ = std::make_shared<const RunMetadata>(truth);
  }
  config_ = config;
  return Check();
}

Status CampaignRig::Check() const {
  std::unique_ptr<RigInterface> probe;
  KCRIG_RETURN_IF_ERROR(connect_("", &probe));
  KCRIG_RETURN_IF_ERROR(probe->Configure());
  probe.reset();
  RigSessionOptions check;
  check.excitation =
      config_.experiment.Excitation(0.0, config_.experiment.z_a_bounds.lower);
  return ValidateRunRequest(rig_config_, check);
}

Status CampaignRig::Run(const RampExcitation<double>& excitation, int run,
                        const std::string& csv_path,
                        const std::atomic<int>* stop,
                        RunMonitor* monitor) const {
  namespace fs = std::filesystem;
  if (fs::path(csv_path).filename() != "run.csv") {
    return Status::Error(csv_path + ": a rig run writes run.csv");
  }
  if (stop->load() != 0) {
    return Status::Error("interrupted by a signal before run " +
                         std::to_string(run));
  }
  const std::string log_dir = fs::path(csv_path).parent_path().string();
  std::unique_ptr<RigInterface> link;
  KCRIG_RETURN_IF_ERROR(connect_(log_dir, &link));
  KCRIG_RETURN_IF_ERROR(link->Configure());
  RigSessionOptions options;
  options.excitation = excitation;
  options.log_dir = log_dir;
  options.stop_signal = stop;
  options.clock = clock_;
  options.truth = truth_.get();
  options.monitor = monitor;
  RigSessionResult result;
  KCRIG_RETURN_IF_ERROR(
      RunRigSession(config_, rig_config_, link.get(), options, &result));
  if (!result.completed) {
    return Status::Error("run " + std::to_string(run) + " on " + name_ + " " +
                         result.trip_message + " (log in " + log_dir + ")");
  }
  return Status::Ok();
}

}  // namespace kcrig
