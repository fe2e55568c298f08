#include "diagnosis/internal/residual_statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace kcrig {
double LaggedCorrelation(const std::vector<double>& a,
                         const std::vector<double>& b, int lag) {
  const int n = static_cast<int>(a.size());
  double sa = 0, sb = 0, saa = 0, sbb = 0, sab = 0;
  int count = 0;
  for (int j = std::max(0, lag); j < std::min(n, n + lag); ++j) {
    const double x = a[j], y = b[j - lag];
    sa += x;
    sb += y;
    saa += x * x;
    sbb += y * y;
    sab += x * y;
    ++count;
  }
  if (count < 3) return 0;
  const double cov = sab - sa * sb / count;
  const double va = saa - sa * sa / count, vb = sbb - sb * sb / count;
  return va > 0 && vb > 0 ? cov / std::sqrt(va * vb) : 0;
}

}  // namespace kcrig
