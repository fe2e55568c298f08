#include "emulator/sil_rig.h"

#include <cmath>
#include <functional>
#include <limits>
#include <optional>
#include <utility>

#include "nlohmann/json.hpp"

namespace kcrig {
namespace {

using Kind = InjectedFault::Kind;

constexpr const char* kName = "embedded SIL rig (virtual clock)";

// The loop's side of the SIL rig: what a transport does, without one. Each
// request first advances the rig to the clock's time, as the emulator's
// front ends do.
class SilLink final : public RigInterface {
 public:
  // `begin_run` readies the rig for this run (its rest since the last one)
  // and gives the run's session token.
  SilLink(RigEmulator* rig, VirtualClock* clock,
          std::function<Status(std::uint16_t*)> begin_run,
          std::vector<InjectedFault> faults)
      : rig_(rig),
        clock_(clock),
        begin_run_(std::move(begin_run)),
        faults_(std::move(faults)) {}

  Status Configure() override { return Status::Ok(); }

  // Claim and reset a latched fault, then enable at zero force, then see
  // the rig report itself enabled (as the transports do).
  Status Activate() override {
    KCRIG_RETURN_IF_ERROR(begin_run_(&session_));
    if (!Send(RigCommand(), /*claim=*/true, /*release=*/false, true)) {
      return Status::Error(kName +
                           std::string(": another session holds the rig"));
    }
    RigCommand enable;
    enable.enable = true;
    Send(enable, true, false, false);
    const std::uint16_t status = rig_->status();
    if (!(status & kRigEnabled) || (status & kRigFault)) {
      return Status::Error(
          kName +
          std::string(": the rig did not report itself enabled "
                      "(fault code ") +
          std::to_string(rig_->fault()) + ")");
    }
    return Status::Ok();
  }

  Status Deactivate() override {
    Send(RigCommand(), false, /*release=*/true, false);
    return Status::Ok();
  }
  void OnError() override { Deactivate(); }

  IoResult Read(RigMeasurement* measurement) override {
    const std::int64_t read = reads_++;
    if (const InjectedFault* late = Find(Kind::kLate, read)) {
      clock_->Advance(std::llround(late->delay * 1e9));
    }
    // The rig lives on whatever reaches the loop (its own watchdog too).
    rig_->AdvanceTo(clock_->Seconds());
    if (Active(Kind::kSilent, read)) return IoResult::kError;
    if (Active(Kind::kStale, read)) return IoResult::kStale;
    if (Find(Kind::kEstop, read) != nullptr) rig_->EmergencyStop();
    if (Find(Kind::kForeign, read) != nullptr) ForeignCommand();
    RigMeasurement m = rig_->TakeSample();
    if (Find(Kind::kLost, read) != nullptr) return IoResult::kError;
    Garble(read, &m);
    *measurement = m;
    // The rig echoes a command this controller did not send.
    if (rig_->last_sequence() != last_obeyed_) return IoResult::kForeign;
    return IoResult::kFresh;
  }

  IoResult Write(const RigCommand& command) override {
    if (Active(Kind::kSilent, reads_ - 1)) return IoResult::kError;
    return Send(command, false, false, false) ? IoResult::kFresh
                                              : IoResult::kError;
  }

  std::string Describe() const override { return kName; }

  std::string CountersJson() const override {
    nlohmann::ordered_json counters;
    counters["clock"] = "virtual";
    counters["session"] = session_;
    counters["refused_writes"] = rig_->ownership().refused();
    nlohmann::ordered_json injected = nlohmann::ordered_json::array();
    for (const InjectedFault& f : faults_) injected.push_back(f.text);
    counters["injected_faults"] = injected;
    return counters.dump();
  }

 private:
  bool Send(const RigCommand& command, bool claim, bool release,
            bool reset_fault) {
    if (!Apply(command, claim, release, reset_fault)) return false;
    last_obeyed_ = command.sequence;
    return true;
  }

  // Another master, through a front end that lets it in under this
  // session: its one command holds the rig's set-point, then it is silent.
  void ForeignCommand() {
    RigCommand command;
    command.enable = true;
    command.force = rig_->actuator_force();
    command.z_a = rig_->plant().z_a();
    command.sequence = static_cast<std::uint16_t>(last_obeyed_ + 0x8000);
    Apply(command, false, false, false);
  }

  bool Apply(const RigCommand& command, bool claim, bool release,
             bool reset_fault) {
    rig_->AdvanceTo(clock_->Seconds());
    RigRequest request;
    request.command = command;
    request.reset_fault = reset_fault;
    request.ownership.has_session = true;
    request.ownership.session = session_;
    request.ownership.claim = claim;
    request.ownership.release = release;
    request.ownership.enable = command.enable;
    return rig_->Request(request);
  }

  // The fault of `kind` that happens at read `read`.
  const InjectedFault* Find(Kind kind, std::int64_t read) const {
    for (const InjectedFault& f : faults_) {
      if (f.kind == kind && f.at == read) return &f;
    }
    return nullptr;
  }

  // Whether a fault of `kind` lasts over read `read`.
  bool Active(Kind kind, std::int64_t read) const {
    for (const InjectedFault& f : faults_) {
      if (f.kind != kind || read < f.at) continue;
      if (kind == Kind::kSilent || read < f.at + f.cycles) return true;
    }
    return false;
  }

  static double* Channel(RigMeasurement* m, int channel) {
    return channel < 6 ? &m->y(channel) : &m->force(channel - 6);
  }

  // Stuck channels, NaN channels, corrupted replies.
  void Garble(std::int64_t read, RigMeasurement* m) {
    for (size_t i = 0; i < faults_.size(); ++i) {
      const InjectedFault& f = faults_[i];
      if (f.kind == Kind::kStuck && read >= f.at) {
        if (!stuck_[i]) stuck_[i] = *Channel(m, f.channel);
        *Channel(m, f.channel) = *stuck_[i];
      }
      if (f.kind == Kind::kNan && read == f.at) {
        *Channel(m, f.channel) = std::numeric_limits<double>::quiet_NaN();
      }
      if (f.kind == Kind::kCorrupt && read == f.at) {
        m->sample ^= 0x5a5a0000u;
        m->y(0) = 3.0e38;  // a float's exponent bits flipped
      }
    }
  }

  RigEmulator* rig_;
  VirtualClock* clock_;
  std::function<Status(std::uint16_t*)> begin_run_;
  std::uint16_t session_ = 0;
  std::vector<InjectedFault> faults_;
  // A stuck channel's value, from the first sample at or after its cycle.
  std::vector<std::optional<double>> stuck_ =
      std::vector<std::optional<double>>(faults_.size());
  std::int64_t reads_ = 0;
  // The sequence of this controller's last command the rig obeyed.
  std::uint16_t last_obeyed_ = 0;
};

}  // namespace

SilRig::SilRig(const KcrigConfig& config, const PlantConfig& plant)
    : plant_(plant), emulator_(config, plant, plant.effects) {}

Status SilRig::Start() { return emulator_.Start(clock_.Seconds()); }

std::unique_ptr<RigInterface> SilRig::Connect(
    std::vector<InjectedFault> faults) {
  return std::make_unique<SilLink>(
      &emulator_, &clock_,
      [this](std::uint16_t* session) { return BeginRun(session); },
      std::move(faults));
}

Status SilRig::BeginRun(std::uint16_t* session) {
  if (ran_) {
    clock_.Advance(std::llround(plant_.rest_between_runs * 1e9));
    emulator_.AdvanceTo(clock_.Seconds());
    if (!plant_.keeps_state) KCRIG_RETURN_IF_ERROR(Start());
  }
  ran_ = true;
  // A session token per run, as each `kcrig run` draws its own.
  *session = next_session_++;
  if (next_session_ == 0 || next_session_ == kOwnerHidden) next_session_ = 1;
  return Status::Ok();
}

RunMetadata SilRig::Truth() const {
  RunMetadata truth;
  truth.synthetic = true;
  truth.noise_added = plant_.noise;
  truth.seed = plant_.seed;
  SuspensionParameters<double> copy = plant_.model;
  for (const NamedParameter<double>& p : ListParameters(&copy)) {
    truth.truth_parameters.emplace_back(p.name, *p.value);
  }
  truth.truth_effects = DescribeEffects(plant_.effects);
  return truth;
}

}  // namespace kcrig
