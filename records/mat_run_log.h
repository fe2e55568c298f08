// The run log as a MATLAB MAT-file (level 5, the layout MathWorks
// publishes; written and read with libmatio): what MATLAB's `load` and
// SciPy's `scipy.io.loadmat` read directly, and what kcrig reads back for
// estimation like a run.csv.
//
// Variables, one per CSV column, each a double column vector of the
// log's samples in SI units: t, Fx, Fy, Fz (absent without a load cell),
// x, y, z, toe, camber, caster, Fx_cmd, Fy_cmd, Fz_cmd (with commanded
// force), fresh (0/1, rig logs); `phase` (rig logs) a cell array of the
// phase names; `sidecar` a char row vector holding run.json's text (the
// units, rate, excitation, sigmas: `jsondecode(sidecar)` in MATLAB,
// `json.loads` in Python).
#ifndef KCRIG_RECORDS_MAT_RUN_LOG_H_
#define KCRIG_RECORDS_MAT_RUN_LOG_H_

#include <string>

#include "base/status.h"
#include "records/run_log.h"

namespace kcrig {

// Whether `path` names a MAT-file (by its `.mat` extension).
bool IsMatRunLog(const std::string& path);

// Writes `log` to `mat_path` atomically (zlib-compressed variables); on
// failure nothing is left there.
Status WriteMatRunLog(const std::string& mat_path, const RunLog& log);

// Reads a MAT-file run log with the checks of ReadRunLog: every channel
// present, a double vector of one length, finite; time increasing; fresh
// 0 or 1; known phases; a sidecar that agrees with the samples. Errors
// name the file and the variable.
Status ReadMatRunLog(const std::string& mat_path, RunLog* log);

}  // namespace kcrig

#endif  // KCRIG_RECORDS_MAT_RUN_LOG_H_
