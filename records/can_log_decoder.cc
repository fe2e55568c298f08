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

}  // namespace

Status DecodeCanLog(const std::string& path,
                    const CanLogDecoderOptions& options, RunLog* log,
                    CanLogCounts* counts) {
  CanLogCounts local;
  if (counts == nullptr) counts = &local;
  *counts = CanLogCounts();
  Dbc dbc;
  Status status = LoadDbc(options.dbc_file, &dbc);
  if (!status.ok()) return status;
  KcRigProtocol protocol;
  status = protocol.Bind(dbc, options.dbc_file);
  if (!status.ok()) return status;
  std::vector<CandumpRecord> records;
  status = ReadCandumpLog(path, &records);
  if (!status.ok()) return status;

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

  KcSampleAssembler assembler(&protocol);
  RigMeasurement latest;
  bool fresh = false, have_setup = false;
  KcSetup setup;
  std::uint16_t fault_code = 0;
  std::int64_t cycle = -1;  // unwrapped command sequence
  std::uint8_t last_sequence = 0;
  int owner = -1;  // the session of the log's first claim or command
  for (const CandumpRecord& record : records) {
    const CanFrame& frame = record.frame.frame;
    ++counts->frames;
    if (frame.error) {
      ++counts->error_frames;
      continue;
    }
    const KcFrame kind = protocol.Classify(frame);
    if (kind == KcFrame::kCount) {
      ++counts->unknown;
      continue;
    }
    if (!protocol.WellFormed(frame, kind)) {
      ++counts->malformed;
      continue;
    }
    bool clamped = false;
    switch (kind) {
      case KcFrame::kSetup:
        setup = protocol.DecodeSetup(frame, &clamped);
        if (setup.protocol != kKcRigProtocolVersion) {
          return Status::Error(
              path + ": a log of CAN protocol " +
              std::to_string(setup.protocol) +
              " (KC_Setup); this kcrig reads " +
              std::to_string(kKcRigProtocolVersion) +
              ": decode it with the kcrig and DBC it was recorded with");
        }
        have_setup = true;
        break;
      case KcFrame::kSession: {
        const KcSession session = protocol.DecodeSession(frame);
        if (owner < 0 && session.claim) owner = session.session;
        break;
      }
      case KcFrame::kHeartbeat:
        fault_code = protocol.DecodeHeartbeat(frame).fault_code;
        break;
      case KcFrame::kCommand: {
        const KcCommand command = protocol.DecodeCommand(frame, &clamped);
        if (owner < 0) owner = command.session;  // a capture from mid-run
        if (command.session != owner) {
          ++counts->foreign;  // another controller's, refused by the rig
          break;
        }
        if (setup.phase == 0) break;  // lifecycle, outside the loop
        if (!have_setup || setup.period <= 0) {
          return Status::Error(path +
                               ": no KC_Setup (acting height, cycle period) "
                               "before the first loop command");
        }
        ++counts->commands;
        const std::int64_t step =
            cycle < 0
                ? 0
                : static_cast<std::uint8_t>(command.sequence - last_sequence);
        if (cycle >= 0 && step == 0) break;  // a repeated frame
        // Cycles skipped by the controller: rows without a fresh sample.
        for (std::int64_t k = 1; k < step && !log->samples.empty(); ++k) {
          LogSample filler = log->samples.back();
          filler.t = static_cast<double>(cycle + k) * setup.period;
          filler.fresh = false;
          log->samples.push_back(filler);
        }
        // The first loop cycle is below 256: its sequence is its index.
        cycle = cycle < 0 ? command.sequence : cycle + step;
        last_sequence = command.sequence;
        LogSample row;
        row.t = static_cast<double>(cycle) * setup.period;
        row.force = latest.force;
        row.y = latest.y;
        row.commanded = command.force;
        row.fresh = fresh;
        row.phase = PhaseName(setup.phase);
        row.safety = setup.safety;
        row.rig_sample = latest.sample;
        row.rig_status = latest.status;
        log->samples.push_back(row);
        m.excitation.z_a = setup.z_a;
        m.rate = 1.0 / setup.period;
        fresh = false;
        break;
      }
      default:
        if (assembler.Add(frame, kind, &latest)) {
          latest.fault_code = fault_code;
          fresh = true;
          ++counts->samples;
        }
        break;
    }
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
