#include "designer/criteria.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include "Eigen/Eigenvalues"

namespace kcrig {
namespace {

// Eigen-decomposition of I with the eigenvalue floor applied.
struct FlooredEigen {
  Eigen::VectorXd values;
  Eigen::MatrixXd vectors;
  bool singular = false;
};

FlooredEigen Decompose(const Eigen::MatrixXd& information) {
  const int n = static_cast<int>(information.rows());
  FlooredEigen result;
  if (!information.allFinite()) {
    result.values = Eigen::VectorXd::Constant(n, kAbsoluteEigenvalueFloor);
    result.vectors = Eigen::MatrixXd::Identity(n, n);
    result.singular = true;
    return result;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(
      0.5 * (information + information.transpose()));
  result.values = solver.eigenvalues();
  result.vectors = solver.eigenvectors();
  const double floor =
      std::max(kRelativeEigenvalueFloor * result.values.maxCoeff(),
               kAbsoluteEigenvalueFloor);
  for (int i = 0; i < n; ++i) {
    if (!(result.values(i) >= floor)) {
      result.values(i) = floor;
      result.singular = true;
    }
  }
  return result;
}

Eigen::VectorXd InverseDiagonal(const FlooredEigen& e) {
  return e.vectors.array().square().matrix() * e.values.cwiseInverse();
}

}  // namespace

Status ParseCriterion(const std::string& text, Criterion* criterion) {
  std::string upper = text;
  std::transform(upper.begin(), upper.end(), upper.begin(),
                 [](unsigned char c) { return std::toupper(c); });
  if (upper == "D") {
    *criterion = Criterion::kD;
  } else if (upper == "A") {
    *criterion = Criterion::kA;
  } else if (upper == "E") {
    *criterion = Criterion::kE;
  } else if (upper == "MM") {
    *criterion = Criterion::kMM;
  } else {
    return Status::Error("--criterion " + text + ": expected D, A, E or MM");
  }
  return Status::Ok();
}

const char* CriterionName(Criterion criterion) {
  switch (criterion) {
    case Criterion::kD:
      return "D";
    case Criterion::kA:
      return "A";
    case Criterion::kE:
      return "E";
    case Criterion::kMM:
      return "MM";
  }
  return "?";
}

bool IsMaxType(Criterion criterion) {
  return criterion == Criterion::kE || criterion == Criterion::kMM;
}

CriterionValue EvaluateCriterion(Criterion criterion,
                                 const Eigen::MatrixXd& information) {
  const FlooredEigen e = Decompose(information);
  CriterionValue result;
  result.singular = e.singular;
  Eigen::VectorXd g;  // the epigraph functions of E and MM
  switch (criterion) {
    case Criterion::kD:
      result.value = -e.values.array().log().sum();
      break;
    case Criterion::kA:
      result.value = e.values.cwiseInverse().mean();
      break;
    case Criterion::kE:
      g = e.values.cwiseInverse();
      result.value = g.maxCoeff();
      break;
    case Criterion::kMM:
      g = InverseDiagonal(e);
      result.value = g.maxCoeff();
      break;
  }
  result.epigraph = IsMaxType(criterion)
                        ? std::vector<double>(g.data(), g.data() + g.size())
                        : std::vector<double>{result.value};
  return result;
}

double OptimizationScale(Criterion criterion, double value) {
  return criterion == Criterion::kD ? value : std::log(value);
}

}  // namespace kcrig
