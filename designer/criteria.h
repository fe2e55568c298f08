// Optimality criteria of the experimental design (paper eqs. 10-13) on the
// information matrix I of the scaled parameters:
//   D  = -ln det I              (volume of the confidence ellipsoid)
//   A  = trace(I^-1) / n_p      (mean relative variance)
//   E  = lambda_max(I^-1)       (longest semi-axis, squared)
//   MM = max_i (I^-1)_ii        (largest relative variance)
// E and MM are not differentiable where their maximum changes hands; their
// epigraph form  min t  s.t.  g_k(v) <= t  has smooth constraints g_k
// (CriterionValue::epigraph).
#ifndef KCRIG_DESIGNER_CRITERIA_H_
#define KCRIG_DESIGNER_CRITERIA_H_

#include <string>
#include <vector>

#include "Eigen/Core"
#include "base/status.h"

namespace kcrig {

enum class Criterion { kD, kA, kE, kMM };

// "D", "A", "E" or "MM" (case-insensitive).
Status ParseCriterion(const std::string& text, Criterion* criterion);
const char* CriterionName(Criterion criterion);
// E and MM are max-type criteria, solved in epigraph form.
bool IsMaxType(Criterion criterion);

// Singular or near-singular I: eigenvalues below
//   floor = max(kRelativeEigenvalueFloor * lambda_max,
//   kAbsoluteEigenvalueFloor)
// are raised to the floor before the criterion is computed, and the value
// is flagged. The criterion is then finite and continuous, and large: an
// eigenvalue of 1e-6 stands for a relative standard error of 1000 in that
// direction of parameter space. A matrix with non-finite entries (a
// diverged simulation) is treated as carrying no information (I = 0).
inline constexpr double kRelativeEigenvalueFloor = 1e-12;
inline constexpr double kAbsoluteEigenvalueFloor = 1e-6;

struct CriterionValue {
  double value = 0;
  bool singular = false;  // some eigenvalue was raised to the floor
  // The constraint functions of the epigraph form, each smooth in the
  // design: MM: the diagonal of I^-1; E: the eigenvalues of I^-1 (as a set
  // they are the values of smooth eigenvalue branches); their maximum is
  // the criterion. D and A: the criterion itself.
  std::vector<double> epigraph;
};

CriterionValue EvaluateCriterion(Criterion criterion,
                                 const Eigen::MatrixXd& information);

// What the optimizers minimize: D itself (already a logarithm), the
// logarithm of A, E and MM. Monotone, so the minimizer is the same; the
// logarithm makes relative changes of a variance equally important at any
// level and keeps the surrogate's and the quasi-Newton model's scale sane.
double OptimizationScale(Criterion criterion, double value);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_CRITERIA_H_
