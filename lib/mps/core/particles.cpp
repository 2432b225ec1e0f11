#include "mps/core/particles.hpp"

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

template <int D>
void BasicParticles<D>::add(const Vec<D>& r, Kind k, int grp, const Vec<D>& vel) {
  for_each_field([](const char*, auto& field) { field.emplace_back(); });  // every field, each at its default
  const auto pos = this->positions();
  const auto velocity = this->velocities();
  for (std::size_t d = 0; d < D; ++d) {
    pos[d]->back() = r[d];
    velocity[d]->back() = vel[d];
  }
  kind.back() = k;
  group.back() = grp;
  id.back() = static_cast<int>(id.size() - 1);
}

template <int D>
void BasicParticles<D>::reserve(std::size_t n) {
  for_each_field([n](const char*, auto& field) { field.reserve(n); });
}

template <int D>
std::size_t BasicParticles<D>::count(Kind k) const {
  return static_cast<std::size_t>(std::count(kind.begin(), kind.end(), k));
}

template <int D>
void BasicParticles<D>::permute(std::span<const int> order) {
  if (order.size() != size()) throw std::invalid_argument("Particles::permute: order has the wrong length");
  for_each_field([order](const char*, auto& field) {
    std::remove_reference_t<decltype(field)> out(field.size());
    for (std::size_t i = 0; i < order.size(); ++i) out[i] = field[static_cast<std::size_t>(order[i])];
    field.swap(out);
  });
}

template <int D>
Vec<D> BasicParticles<D>::position(std::size_t i) const {
  Vec<D> r;
  const auto pos = this->positions();
  for (std::size_t d = 0; d < D; ++d) r[d] = (*pos[d])[i];
  return r;
}

template <int D>
Vec<D> BasicParticles<D>::velocity(std::size_t i) const {
  Vec<D> r;
  const auto vel = this->velocities();
  for (std::size_t d = 0; d < D; ++d) r[d] = (*vel[d])[i];
  return r;
}

template struct BasicParticles<2>;
template struct BasicParticles<3>;

}  // namespace mps
