// The HTML report: one self-contained page (plotly.js and the data inlined,
// no network needed to view it) with the figures a rig engineer looks at
// after a campaign, a diagnosis or a timing check:
//   - measured vs model time histories with the residual, per experiment;
//   - log10 diag((J^T J)^-1) per parameter before and after the designed
//     experiments (the paper's Figs. 4 and 6) and the estimates with their
//     95 % intervals per campaign iteration;
//   - per iteration that designed, the D and A criterion surfaces over
//     (phi, z_a) that its optimizer searched (the designer's, from the
//     estimate and information matrix in its est.json) with the optimizer's
//     evaluated points, path and optimum (Fig. 5), and the kriging surrogate
//     as its samples were refined (Fig. 2);
//   - diagnosis: residual energy by channel x load regime, the candidate
//     ranking, and held-out data against the nominal and attributed models;
//   - timing: wake-up latency and compute-time histograms with the budget,
//     overruns;
//   - validation (`kcrig validate`): the confusion matrix, the detection
//     rate against the effect's size in noise units per class (the power
//     curve), and every case's size and outcome.
// Units as engineers read them: mm, deg, kN, N/mm, us.
#ifndef KCRIG_REPORT_REPORT_H_
#define KCRIG_REPORT_REPORT_H_

#include <string>
#include <vector>

#include "base/iteration_callback.h"
#include "base/parallel_for.h"
#include "base/status.h"
#include "rt_core/model/model_config.h"

namespace kcrig {

struct ReportOptions {
  // Grid of the criterion surfaces: points along phi and along z_a over the
  // config's design bounds. 19 x 11 is the paper's 5 deg x 0.05 m spacing;
  // each point of each designed iteration costs one trajectory with
  // sensitivities (all criteria come from the same information matrix).
  int surface_phi_points = 19;
  int surface_z_points = 11;
  // At most this many samples per plotted time history (evenly decimated):
  // a 4 s log at 1 kHz reads as well at 1000 points and keeps the page
  // small.
  int max_plot_samples = 1000;
  // The protocol's DBC (rig.yaml can.dbc), to decode a diagnosis' CAN bus
  // log for its overlay; "" leaves such an overlay out with a note.
  std::string dbc_file;
  // Threads for the surface evaluations.
  int num_threads = kDefaultThreads;
  // The plotly.js bundle inlined into the page (Debian: python3-plotly).
  std::string plotly_js = KCRIG_PLOTLY_JS;
  // Asked at each stage ("criterion surfaces iteration_1", "time histories
  // 2/4", "diagnosis diag.json"); kAbort stops the report with
  // Interrupted() before anything is written. Optional.
  IterationCallback callback;
};

// What the report found in the folder (for the caller's summary line).
struct ReportSummary {
  int figures = 0;
  int experiments = 0;
  bool campaign = false, diagnosis = false, timing = false, validation = false;
  // A campaign's K&C sheet: the channels on which the final model and the
  // rig differ (|z| > 3 on a gradient or loop width of some run).
  std::vector<std::string> kc_differing_channels;
};

// The K&C sheet's verdict in one line, for a campaign report: the channels
// on which the final model and the rig differ, or that they agree.
std::string KcSheetLine(const ReportSummary& summary);

// Reads a campaign output folder `from_dir` (campaign.json and its
// iteration_*/ folders; a diag.json and timing.json there or in an
// iteration folder are picked up too, and a validate.json anywhere in it)
// and writes the report to
// `html_path` atomically. Errors name the file and field; nothing is
// written then. A folder with none of these files is an error.
Status WriteReport(const KcrigConfig& config, const std::string& from_dir,
                   const std::string& html_path, const ReportOptions& options,
                   ReportSummary* summary);

}  // namespace kcrig

#endif  // KCRIG_REPORT_REPORT_H_
