// The decoded run log: CSV with header t,Fx,Fy,Fz,x,y,z,toe,camber,caster
// (s, N, m, rad; Fx,Fy,Fz absent when the rig has no load cell), optionally
// followed by Fx_cmd,Fy_cmd,Fz_cmd and, from a rig run, the loop's columns
// fresh,phase,safety,rig_sample,rig_status,x_model..caster_model; and a JSON
// sidecar with the same stem (run.csv -> run.json). Both files appear
// together or not at all: they are written to temporaries and renamed.
#ifndef KCRIG_RECORDS_RUN_LOG_H_
#define KCRIG_RECORDS_RUN_LOG_H_

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "base/status.h"
#include "rt_core/model/excitation.h"
#include "rt_core/model/rotation.h"

namespace kcrig {

class PartialFile;

struct LogSample {
  double t = 0;                                   // [s]
  Vec3<double> force = Vec3<double>::Zero();      // on the wheel [N]
  Vec6<double> y = Vec6<double>::Zero();          // x, y, z [m], angles [rad]
  Vec3<double> commanded = Vec3<double>::Zero();  // only with commanded force
  // A rig log's loop columns (RunLog::has_loop_columns): whether a new rig
  // sample arrived in this cycle (else force and y repeat the last one),
  // the run phase and safety state, the rig's sample counter and status,
  // and the live model prediction relative to the rest pose.
  bool fresh = true;
  // Static strings: RunPhaseName(); empty in logs without a phase column.
  std::string_view phase;
  int safety = 0;  // SafetyState
  std::uint32_t rig_sample = 0;
  std::uint16_t rig_status = 0;
  Vec6<double> predicted = Vec6<double>::Zero();
};

struct RunMetadata {
  double rate = 0;  // [Hz]
  // The experiment that was run (or simulated).
  RampExcitation<double> excitation;
  double sigma_position = 0;  // [m]
  double sigma_angle = 0;     // [rad]
  std::string transport;      // "simulation", "modbus-tcp://...", "can:vcan0"
  // GeometryFingerprint of the configured model the log was recorded with
  // ("" in logs from before it was recorded).
  std::string geometry;
  bool noise_added = false;
  std::uint64_t seed = 0;
  // Synthetic data only: the true parameter values and the plant's effects.
  bool synthetic = false;
  std::vector<std::pair<std::string, double>> truth_parameters;
  std::vector<std::string> truth_effects;
  // Rig runs: a JSON object with the run's phases, safety outcome and loop
  // counters, written to the sidecar as "hil" (not read back).
  std::string hil_json;
};

struct RunLog {
  std::vector<LogSample> samples;
  // Without a load cell the log has no Fx, Fy, Fz columns; the force is then
  // the commanded excitation of the sidecar (LogSample::force stays zero).
  bool has_measured_force = true;
  bool has_commanded_force = false;
  // fresh,phase,safety,rig_sample,rig_status,x_model..caster_model after
  // the channels (written by `kcrig run`; the reader uses `fresh`).
  bool has_loop_columns = false;
  RunMetadata metadata;
};

// The magnitude beyond which a logged value of `column` is no measurement
// of a K&C rig but a unit slip or a corrupt field: forces (Fx.., Fx_cmd..)
// 1 MN, positions 10 m, angles 7 rad; 0 for a column without one. Both
// readers (CSV, MAT) refuse such a value, naming it.
double PhysicalLimit(std::string_view column);
// "1 MN" style text of that limit with its unit, for messages.
std::string PhysicalLimitText(std::string_view column);

// run.csv -> run.json
std::string SidecarPath(const std::string& csv_path);

// Writes csv_path and its sidecar atomically; on failure neither exists.
Status WriteRunLog(const std::string& csv_path, const RunLog& log);

// For writers that stream a log row by row as it is recorded (kcrig run):
// the header line and one row, exactly as WriteRunLog writes them (the
// columns follow log's flags).
std::string RunLogCsvHeader(const RunLog& log);
void AppendRunLogCsvRow(const RunLog& log, const LogSample& sample,
                        std::string* csv);

// Completes a streamed log of `rows` rows: closes `csv`, writes the sidecar
// of `log` (its metadata and columns; its samples are not used) and commits
// `csv` under its final name. Until then only the partial file exists, so a
// crash leaves no run.csv without sidecar; when the commit fails the sidecar
// is removed again.
Status FinishStreamedRunLog(PartialFile* csv, const RunLog& log,
                            std::int64_t rows);

// The sidecar alone, for `rows` rows of the log at `csv_path` (a streamed
// log whose writing failed keeps its whole rows in the partial file).
Status WriteRunLogSidecar(const std::string& csv_path, const RunLog& log,
                          std::int64_t rows);

// Reads a run log and its sidecar, checking everything an estimator relies
// on: the header has every channel, each row is complete and finite, time
// increases strictly, the file ends with a complete line, and the sidecar
// agrees with the CSV (sample count, rate). Errors name file and line.
// The truth block of a synthetic sidecar is not read: estimation never sees
// it.
Status ReadRunLog(const std::string& csv_path, RunLog* log);

}  // namespace kcrig

#endif  // KCRIG_RECORDS_RUN_LOG_H_
