#include "records/can_log_decoder.h"

#include <cmath>

#include "io_drivers/kc_rig_protocol.h"
#include "records/internal/candump_log.h"
#include "rt_core/model/excitation.h"

namespace kcrig {
namespace {

// KC_Setup's Phase (1 + RunPhase) as the run log names it.
const char* PhaseName(int wire) {
  if (wire >= 1 && wire <= static_cast<int>(RunPhase::kDone) + 1) {
    return RunPhaseName(static_cast<RunPhase>(wire - 1));
  }
  return "unknown";
}

// Rebuilds the controller's rows from the frames, in order: the last
// sample the rig sent, the KC_Setup in force, the owner's commands with
// their sequence unwrapped (a cycle the controller skipped is a row without
// a fresh sample).
class RowAssembler {
 public:
  RowAssembler(const KcRigProtocol& protocol, const std::string& path,
               RunLog* log, CanLogCounts* counts)
      : protocol_(protocol),
        samples_(&protocol),
        path_(path),
        log_(log),
        counts_(counts) {}

  Status Add(const CanFrame& frame) {
    ++counts_->frames;
    if (frame.error) {
      ++counts_->error_frames;
      return Status::Ok();
    }
    const KcFrame kind = protocol_.Classify(frame);
    if (kind == KcFrame::kCount) {
      ++counts_->unknown;
      return Status::Ok();
    }
    if (!protocol_.WellFormed(frame, kind)) {
      ++counts_->malformed;
      return Status::Ok();
    }
    switch (kind) {
      case KcFrame::kSetup:
        return OnSetup(frame);
      case KcFrame::kSession: {
        const KcSession session = protocol_.DecodeSession(frame);
        if (owner_ < 0 && session.claim) owner_ = session.session;
        return Status::Ok();
      }
      case KcFrame::kHeartbeat:
        fault_code_ = protocol_.DecodeHeartbeat(frame).fault_code;
        return Status::Ok();
      case KcFrame::kCommand:
        return OnCommand(frame);
      default:
        if (samples_.Add(frame, kind, &latest_)) {
          latest_.fault_code = fault_code_;
          fresh_ = true;
          ++counts_->samples;
        }
        return Status::Ok();
    }
  }

 private:
  Status OnSetup(const CanFrame& frame) {
    bool clamped = false;
    setup_ = protocol_.DecodeSetup(frame, &clamped);
    if (setup_.protocol != kKcRigProtocolVersion) {
      return Status::Error(
          path_ + ": a log of CAN protocol " + std::to_string(setup_.protocol) +
          " (KC_Setup); this kcrig reads " +
          std::to_string(kKcRigProtocolVersion) +
          ": decode it with the kcrig and DBC it was recorded with");
    }
    have_setup_ = true;
    return Status::Ok();
  }

  Status OnCommand(const CanFrame& frame) {
    bool clamped = false;
    const KcCommand command = protocol_.DecodeCommand(frame, &clamped);
    if (owner_ < 0) owner_ = command.session;  // a capture from mid-run
    if (command.session != owner_) {
      ++counts_->foreign;  // another controller's, refused by the rig
      return Status::Ok();
    }
    if (setup_.phase == 0) return Status::Ok();  // lifecycle, outside the loop
    if (!have_setup_ || setup_.period <= 0) {
      return Status::Error(path_ +
                           ": no KC_Setup (acting height, cycle period) "
                           "before the first loop command");
    }
    ++counts_->commands;
    const std::int64_t step =
        cycle_ < 0
            ? 0
            : static_cast<std::uint8_t>(command.sequence - last_sequence_);
    if (cycle_ >= 0 && step == 0) return Status::Ok();  // a repeated frame
    // Cycles skipped by the controller: rows without a fresh sample.
    for (std::int64_t k = 1; k < step && !log_->samples.empty(); ++k) {
      LogSample filler = log_->samples.back();
      filler.t = static_cast<double>(cycle_ + k) * setup_.period;
      filler.fresh = false;
      log_->samples.push_back(filler);
    }
    // The first loop cycle is below 256: its sequence is its index.
    cycle_ = cycle_ < 0 ? command.sequence : cycle_ + step;
    last_sequence_ = command.sequence;
    log_->samples.push_back(Row(command));
    log_->metadata.excitation.z_a = setup_.z_a;
    log_->metadata.rate = 1.0 / setup_.period;
    fresh_ = false;
    return Status::Ok();
  }

  LogSample Row(const KcCommand& command) const {
    LogSample row;
    row.t = static_cast<double>(cycle_) * setup_.period;
    row.force = latest_.force;
    row.y = latest_.y;
    row.commanded = command.force;
    row.fresh = fresh_;
    row.phase = PhaseName(setup_.phase);
    row.safety = setup_.safety;
    row.rig_sample = latest_.sample;
    row.rig_status = latest_.status;
    return row;
  }

  const KcRigProtocol& protocol_;
  KcSampleAssembler samples_;
  const std::string& path_;
  RunLog* log_;
  CanLogCounts* counts_;
  RigMeasurement latest_;
  bool fresh_ = false;
  bool have_setup_ = false;
  KcSetup setup_;
  std::uint16_t fault_code_ = 0;
  std::int64_t cycle_ = -1;  // unwrapped command sequence
  std::uint8_t last_sequence_ = 0;
  int owner_ = -1;  // the session of the log's first claim or command
};

}  // namespace

Status DecodeCanLog(const std::string& path,
                    const CanLogDecoderOptions& options, RunLog* log,
                    CanLogCounts* counts) {
  CanLogCounts local;
  if (counts == nullptr) counts = &local;
  *counts = CanLogCounts();
  Dbc dbc;
  KCRIG_RETURN_IF_ERROR(LoadDbc(options.dbc_file, &dbc));
  KcRigProtocol protocol;
  KCRIG_RETURN_IF_ERROR(protocol.Bind(dbc, options.dbc_file));
  std::vector<CandumpRecord> records;
  KCRIG_RETURN_IF_ERROR(ReadCandumpLog(path, &records));

  *log = RunLog();
  log->has_measured_force = true;
  log->has_commanded_force = true;
  // fresh, phase, safety, rig sample and status are per row; the model
  // prediction is not on the bus, so no loop columns are claimed.
  log->has_loop_columns = false;
  RunMetadata& m = log->metadata;
  m.sigma_position = options.sigma_position;
  m.sigma_angle = options.sigma_angle;
  m.transport = records.empty() ? "can" : "can:" + records[0].interface;
  RowAssembler rows(protocol, path, log, counts);
  for (const CandumpRecord& record : records) {
    KCRIG_RETURN_IF_ERROR(rows.Add(record.frame.frame));
  }
  if (log->samples.size() < 2) {
    return Status::Error(path +
                         ": fewer than two controller cycles (KC_Command "
                         "frames after a KC_Setup with a run phase) in the "
                         "log");
  }
  return Status::Ok();
}

}  // namespace kcrig
