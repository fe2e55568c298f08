// The difference stencil u +- h e_i in the unit box, shared by implicit
// filtering (its gradient at scale h) and the NLopt gradient drivers:
// points outside the box are left out and the difference is one-sided
// there.
#ifndef KCRIG_DESIGNER_INTERNAL_STENCIL_H_
#define KCRIG_DESIGNER_INTERNAL_STENCIL_H_

#include <vector>

#include "Eigen/Core"
#include "designer/design_objective.h"

namespace kcrig {

class Stencil {
 public:
  Stencil(const Eigen::Vector2d& centre, double h) : centre_(centre) {
    // "Outside" with a little slack: a point a rounding error beyond a
    // bound is projected onto it rather than dropped.
    constexpr double kBoundSlack = 1e-12;
    for (int i = 0; i < 2; ++i) {
      for (int side = 0; side < 2; ++side) {
        Eigen::Vector2d p = centre;
        p(i) += side == 0 ? -h : h;
        if (p(i) < -kBoundSlack || p(i) > 1 + kBoundSlack) continue;
        index_[i][side] = static_cast<int>(points_.size());
        points_.push_back(p.cwiseMax(0.0).cwiseMin(1.0));
      }
    }
  }

  // The stencil points inside the box (the centre is not among them).
  const std::vector<Eigen::Vector2d>& points() const { return points_; }

  // The gradient of f (a function of an evaluation) from its value at the
  // centre and the evaluations of points(), in order: central differences,
  // one-sided where a point is missing, 0 along an axis with none.
  template <typename F>
  Eigen::Vector2d Gradient(double f_centre,
                           const std::vector<DesignEvaluation>& values,
                           const F& f) const {
    Eigen::Vector2d gradient;
    for (int i = 0; i < 2; ++i) {
      const int minus = index_[i][0], plus = index_[i][1];
      if (minus >= 0 && plus >= 0) {
        gradient(i) = (f(values[plus]) - f(values[minus])) /
                      (points_[plus](i) - points_[minus](i));
      } else if (plus >= 0) {
        gradient(i) =
            (f(values[plus]) - f_centre) / (points_[plus](i) - centre_(i));
      } else if (minus >= 0) {
        gradient(i) =
            (f(values[minus]) - f_centre) / (points_[minus](i) - centre_(i));
      } else {
        gradient(i) = 0;
      }
    }
    return gradient;
  }

 private:
  Eigen::Vector2d centre_;
  std::vector<Eigen::Vector2d> points_;
  int index_[2][2] = {{-1, -1}, {-1, -1}};  // [axis][minus, plus]
};

}  // namespace kcrig

#endif  // KCRIG_DESIGNER_INTERNAL_STENCIL_H_
