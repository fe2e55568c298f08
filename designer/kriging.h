// A kriging (Gaussian-process) surrogate in the manner of the DACE toolbox
// (Lophaven, Nielsen, Sondergaard 2002) that the paper's DACE+SNOPT used:
//   y(x) = f(x)^T beta + Z(x),  corr(Z(x), Z(w)) = exp(-sum_l theta_l (x_l -
//   w_l)^2)
// with a constant, linear or quadratic regression f, beta by generalized
// least squares and theta by maximum likelihood (DACE's objective
// sigma^2 det(R)^(1/m)). Inputs are the unit box; outputs are normalized
// internally.
#ifndef KCRIG_DESIGNER_KRIGING_H_
#define KCRIG_DESIGNER_KRIGING_H_

#include <vector>

#include "Eigen/Core"
#include "base/status.h"
#include "designer/optimizers.h"

namespace kcrig {

struct KrigingOptions {
  KrigingRegression regression = KrigingRegression::kQuadratic;
  // Box for each theta_l (unit inputs): 1e-2 is nearly flat, 1e4 decorrelates
  // at a distance of 0.03 of the box.
  double theta_lower = 1e-2;
  double theta_upper = 1e4;
  // Added to R's diagonal as DACE does ((10 + m) eps), larger here because
  // refinement clusters points near the optimum.
  double nugget = 1e-10;
};

class KrigingModel {
 public:
  // Fits to m points x (in the unit box) with values y; m must exceed the
  // number of regression terms. `theta_start` (may be empty) seeds the
  // likelihood search (warm start from the previous fit).
  Status Fit(const std::vector<Eigen::Vector2d>& x,
             const std::vector<double>& y, const KrigingOptions& options,
             const Eigen::Vector2d* theta_start = nullptr);

  // The predictor at `x`; `mse` (optional) the predictor's mean squared
  // error (0 at the data points, up to the process variance far from them).
  double Predict(const Eigen::Vector2d& x, double* mse = nullptr) const;

  const Eigen::Vector2d& theta() const { return theta_; }

  // Concentrated negative log-likelihood term sigma^2 det(R)^(1/m) for
  // theta (normalized data); +inf when R is not positive definite.
  double LikelihoodObjective(const Eigen::Vector2d& theta) const;

 private:
  Eigen::RowVectorXd Regressors(const Eigen::Vector2d& x) const;
  // Builds the model for theta; false when R is not positive definite.
  bool Build(const Eigen::Vector2d& theta);

  KrigingOptions options_;
  Eigen::MatrixXd x_;  // m x 2
  Eigen::VectorXd y_;  // normalized
  double y_mean_ = 0, y_scale_ = 1;
  Eigen::Vector2d theta_ = Eigen::Vector2d::Ones();
  // For the predictor.
  Eigen::MatrixXd chol_l_;   // R = L L^T
  Eigen::MatrixXd f_tilde_;  // L^-1 F
  Eigen::MatrixXd g_r_;      // R-factor of QR(L^-1 F)
  Eigen::VectorXd beta_;
  Eigen::VectorXd gamma_;  // R^-1 (y - F beta)
  double sigma2_ = 0;
};

// A kriging search's surrogate as it stood after batch `batch` of its
// `record`: fitted (default options) to the evaluations up to that batch, on
// the scale the search fitted (OptimizationScale of `criterion`), in unit
// coordinates over `bounds`. `samples` gets how many it was fitted to.
Status RefitSurrogate(const std::vector<DesignEvaluation>& record,
                      Criterion criterion, const DesignBounds& bounds,
                      int batch, KrigingModel* model, int* samples);

// Expected improvement below `best` of a Gaussian prediction.
double ExpectedImprovement(double best, double prediction, double mse);

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_KRIGING_H_
