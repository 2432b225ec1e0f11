#include "mps/particles.hpp"

#include <algorithm>
#include <stdexcept>

namespace mps {

std::string_view to_string(Kind kind) {
  switch (kind) {
    case Kind::fluid: return "fluid";
    case Kind::wall: return "wall";
    case Kind::dummy: return "dummy";
    case Kind::ghost: return "ghost";
  }
  return "unknown";
}

void Particles::add(double px, double py, Kind k, int grp, double pu, double pv) {
  x.push_back(px);
  y.push_back(py);
  u.push_back(pu);
  v.push_back(pv);
  p.push_back(0.0);
  kind.push_back(k);
  group.push_back(grp);
  id.push_back(static_cast<int>(id.size()));
}

void Particles::reserve(std::size_t n) {
  x.reserve(n);
  y.reserve(n);
  u.reserve(n);
  v.reserve(n);
  p.reserve(n);
  kind.reserve(n);
  group.reserve(n);
  id.reserve(n);
}

std::size_t Particles::count(Kind k) const {
  return static_cast<std::size_t>(std::count(kind.begin(), kind.end(), k));
}

namespace {
template <class T>
void apply_order(std::vector<T>& a, std::span<const int> order) {
  std::vector<T> out(a.size());
  for (std::size_t i = 0; i < order.size(); ++i) out[i] = a[static_cast<std::size_t>(order[i])];
  a.swap(out);
}
}  // namespace

void Particles::permute(std::span<const int> order) {
  if (order.size() != size()) throw std::invalid_argument("Particles::permute: order has the wrong length");
  apply_order(x, order);
  apply_order(y, order);
  apply_order(u, order);
  apply_order(v, order);
  apply_order(p, order);
  apply_order(kind, order);
  apply_order(group, order);
  apply_order(id, order);
}

}  // namespace mps
