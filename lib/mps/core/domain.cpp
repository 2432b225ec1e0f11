#include "mps/core/domain.hpp"

#include <cmath>
#include <stdexcept>

namespace mps {

template <int D>
bool BasicDomain<D>::contains(const Vec<D>& r) const {
  const auto lower = this->lower(), upper = this->upper();
  const auto periodic = this->periodic();
  bool inside = true;
  for (std::size_t a = 0; a < D; ++a)
    inside = inside && (periodic[a] || (r[a] >= lower[a] && r[a] <= upper[a])) && std::isfinite(r[a]);
  return inside;
}

namespace {
// fmod(t, L) is t itself for |t| < L, the common case, which skips the library call and gives the same bits.
double remainder_of(double t, double length) { return std::abs(t) < length ? t : std::fmod(t, length); }

void wrap_axis(double& t, double lower, double upper) {
  const double length = upper - lower;
  t = lower + remainder_of(t - lower, length);
  if (t < lower) t += length;
  if (t >= upper) t -= length;
}
}  // namespace

template <int D>
void BasicDomain<D>::wrap(Vec<D>& r) const {
  const auto lower = this->lower(), upper = this->upper();
  const auto periodic = this->periodic();
  for (std::size_t a = 0; a < D; ++a)
    if (periodic[a]) wrap_axis(r[a], lower[a], upper[a]);
}

template <int D>
void BasicDomain<D>::wrap(double& x, double& y) const
  requires(D == 2)
{
  if (this->periodic_x) wrap_axis(x, this->xmin, this->xmax);
  if (this->periodic_y) wrap_axis(y, this->ymin, this->ymax);
}

template <int D>
void BasicDomain<D>::validate() const {
  const auto lower = this->lower(), upper = this->upper();
  for (std::size_t a = 0; a < D; ++a)
    if (!(upper[a] > lower[a]) || !std::isfinite(lower[a]) || !std::isfinite(upper[a]))
      throw std::invalid_argument(D == 2 ? "Domain: need finite bounds with xmax > xmin and ymax > ymin"
                                         : "Domain: need finite bounds with xmax > xmin, ymax > ymin and zmax > zmin");
}

template struct BasicDomain<2>;
template struct BasicDomain<3>;

}  // namespace mps
