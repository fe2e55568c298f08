// A dual number over any scalar S: x = a + e eps with eps^2 = 0; nested
// (S a Dual itself) it carries a second direction and the mixed second
// derivative. The tests' reference for the closed-form derivatives of Q's
// Jacobians (SuspensionModel::DifferentiateJacobians). Only what the model
// evaluates is defined. Constructible from a plain number, so the model's
// constants (T(0), Eigen's Zero and Identity) work for nested scalars too.
#ifndef KCRIG_TESTS_SUPPORT_DUAL_H_
#define KCRIG_TESTS_SUPPORT_DUAL_H_

#include <cmath>
#include <limits>
#include <type_traits>

#include "Eigen/Core"

namespace kcrig {

template <typename S>
struct Dual {
  S a;  // value
  S e;  // derivative along the dual direction

  Dual() : a(), e() {}
  template <typename U, typename = std::enable_if_t<std::is_arithmetic_v<U>>>
  Dual(U value) : a(static_cast<double>(value)), e() {}  // NOLINT: constants
  Dual(const S& value, const S& derivative) : a(value), e(derivative) {}

  Dual& operator+=(const Dual& y) { return *this = *this + y; }
  Dual& operator-=(const Dual& y) { return *this = *this - y; }
  Dual& operator*=(const Dual& y) { return *this = *this * y; }
  Dual& operator/=(const Dual& y) { return *this = *this / y; }

  friend Dual operator+(const Dual& x) { return x; }
  friend Dual operator-(const Dual& x) { return {-x.a, -x.e}; }
  friend Dual operator+(const Dual& x, const Dual& y) {
    return {x.a + y.a, x.e + y.e};
  }
  friend Dual operator-(const Dual& x, const Dual& y) {
    return {x.a - y.a, x.e - y.e};
  }
  friend Dual operator*(const Dual& x, const Dual& y) {
    return {x.a * y.a, x.a * y.e + x.e * y.a};
  }
  friend Dual operator/(const Dual& x, const Dual& y) {
    const S inverse = S(1.0) / y.a;
    const S quotient = x.a * inverse;
    return {quotient, (x.e - quotient * y.e) * inverse};
  }
};

template <typename S>
Dual<S> sqrt(const Dual<S>& x) {
  using std::sqrt;
  const S root = sqrt(x.a);
  return {root, x.e / (S(2.0) * root)};
}
template <typename S>
Dual<S> sin(const Dual<S>& x) {
  using std::cos;
  using std::sin;
  return {sin(x.a), cos(x.a) * x.e};
}
template <typename S>
Dual<S> cos(const Dual<S>& x) {
  using std::cos;
  using std::sin;
  return {cos(x.a), -sin(x.a) * x.e};
}

}  // namespace kcrig

namespace Eigen {

template <typename S>
struct NumTraits<kcrig::Dual<S>> : NumTraits<double> {
  using Real = kcrig::Dual<S>;
  using NonInteger = kcrig::Dual<S>;
  using Nested = kcrig::Dual<S>;
  using Literal = kcrig::Dual<S>;
  enum {
    IsComplex = 0,
    IsInteger = 0,
    IsSigned = 1,
    RequireInitialization = 1,
    ReadCost = 2 * NumTraits<S>::ReadCost,
    AddCost = 2 * NumTraits<S>::AddCost,
    MulCost = 3 * NumTraits<S>::MulCost + NumTraits<S>::AddCost
  };
  static Real epsilon() { return Real(std::numeric_limits<double>::epsilon()); }
  static Real dummy_precision() { return Real(1e-12); }
  static Real highest() { return Real(std::numeric_limits<double>::max()); }
  static Real lowest() { return Real(std::numeric_limits<double>::lowest()); }
};

}  // namespace Eigen

#endif  // KCRIG_TESTS_SUPPORT_DUAL_H_
