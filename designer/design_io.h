// design.json (DESIGN.md §4), its writer and reader, and the Table-1-style
// comparison of optimizer runs. Angles are written in degrees (phi_deg),
// heights in metres.
#ifndef KCRIG_DESIGNER_DESIGN_IO_H_
#define KCRIG_DESIGNER_DESIGN_IO_H_

#include <string>
#include <vector>

#include "designer/design_objective.h"
#include "designer/optimizers.h"

namespace kcrig {

// One optimizer run and every evaluation it made.
struct DesignRun {
  OptimizationResult result;
  std::vector<DesignEvaluation> record;
};

// Index of the run with the lowest criterion; `runs` must be non-empty.
size_t BestRun(const std::vector<DesignRun>& runs);

// The best run is the headline (criterion, initial and optimal design with
// values, evaluations, optimizer); "runs" lists all of them with
// their paths and evaluated points.
std::string DesignRunsToJson(Criterion criterion,
                             const std::vector<DesignRun>& runs);

// Reads a design.json back into what DesignRunsToJson wrote: per run the
// result (optimum flagged singular on the best run only) and the record of
// evaluated designs with their values and batches (unit, information and
// epigraph are not stored). Errors name the file and the field.
Status ReadDesign(const std::string& path, Criterion* criterion,
                  std::vector<DesignRun>* runs);

// criterion | Phi(v0) | algorithm | Phi(v*) | nEv | seconds | phi* | z_a*
std::string ComparisonTable(Criterion criterion,
                            const std::vector<DesignRun>& runs);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_DESIGN_IO_H_
