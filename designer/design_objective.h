// The design problem as the optimizers see it: the criterion as a function
// of the design, in unit coordinates u in [0, 1]^2 over the design bounds
// (u0 along phi, u1 along z_a), with an evaluation budget, parallel batches
// and a record of every evaluation.
#ifndef KCRIG_DESIGNER_DESIGN_OBJECTIVE_H_
#define KCRIG_DESIGNER_DESIGN_OBJECTIVE_H_

#include <chrono>
#include <vector>

#include "Eigen/Core"
#include "base/batch_runner.h"
#include "base/iteration_callback.h"
#include "base/parallel_for.h"
#include "designer/criteria.h"
#include "designer/information.h"

namespace kcrig {

struct DesignEvaluation {
  Design design;
  Eigen::Vector2d unit = Eigen::Vector2d::Zero();
  Eigen::MatrixXd information;   // prior + J^T J at the design
  double value = 0;              // the criterion
  std::vector<double> epigraph;  // CriterionValue::epigraph
  bool singular = false;
  int batch = 0;  // which batch evaluated it (0-based)
};

struct ObjectiveOptions {
  // Most criterion evaluations (trajectory + sensitivities each); > 0.
  int budget = 100;
  // A batch of designs runs on this many threads, one design per thread,
  // in this process or, with `batches`, spread over a cluster job's ranks
  // (cluster/ranks.h; every rank then runs the same search). Optional.
  int num_threads = kDefaultThreads;
  const BatchRunner* batches = nullptr;
  // Asked after every batch with the evaluations spent of the budget and
  // the stage "24/100 evaluations, best D -77.1058 at 16.0 deg, -0.500 m,
  // 0.7 s (at most 2 s left)"; kAbort ends the search as if the budget
  // were spent (a batch runs to its end: the grid is one batch), and
  // Optimize returns Interrupted(). Optional.
  IterationCallback callback;
};

class DesignObjective {
 public:
  // `evaluator` must outlive the objective. Bounds and budget must be valid
  // (see Validate).
  DesignObjective(const InformationEvaluator* evaluator, Criterion criterion,
                  const DesignBounds& bounds, ObjectiveOptions options);

  // Budget > 0 and bounds in order.
  static Status Validate(const DesignBounds& bounds,
                         const ObjectiveOptions& options);

  Design ToDesign(const Eigen::Vector2d& unit) const;
  Eigen::Vector2d ToUnit(const Design& design) const;

  // Evaluates the points (clamped to the unit box), in parallel, in order,
  // until the budget is spent; returns one evaluation per point evaluated,
  // so fewer than asked means the budget ran out. A point evaluated before
  // is served from the record without spending budget.
  std::vector<DesignEvaluation> Evaluate(
      const std::vector<Eigen::Vector2d>& points);

  Criterion criterion() const { return criterion_; }
  const DesignBounds& bounds() const { return bounds_; }
  int budget() const { return options_.budget; }
  // 0 once interrupted: the optimizers stop as at the end of the budget.
  int remaining() const {
    return interrupted_ ? 0
                        : options_.budget - static_cast<int>(record_.size());
  }
  const std::vector<DesignEvaluation>& record() const { return record_; }
  // The evaluation with the smallest criterion value; record must be
  // non-empty.
  const DesignEvaluation& best() const;
  double elapsed_seconds() const;
  // The callback asked to stop: nothing more is evaluated.
  bool interrupted() const { return interrupted_; }

 private:
  // The information at a design (the trajectory: what a batch spreads),
  // and the evaluation it gives.
  Eigen::MatrixXd InformationAt(const Eigen::Vector2d& unit) const;
  DesignEvaluation Evaluated(const Eigen::Vector2d& unit,
                             const Eigen::MatrixXd& information) const;
  // Reports the progress after a batch; false: stop.
  bool ReportBatch() const;

  const InformationEvaluator* evaluator_;
  Criterion criterion_;
  DesignBounds bounds_;
  ObjectiveOptions options_;
  std::vector<DesignEvaluation> record_;
  int batches_ = 0;
  bool interrupted_ = false;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_DESIGN_OBJECTIVE_H_
