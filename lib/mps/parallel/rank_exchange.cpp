#include "mps/parallel/rank_exchange.hpp"

#include <mpi.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "mps/core/state.hpp"
#include "mps/step/components.hpp"
#include "mps/step/step.hpp"

namespace mps {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

}  // namespace

template <int D>
BasicRankExchange<D>::BasicRankExchange(int comm, DistributedOptions options) : comm_(comm), options_(options) {
  const MPI_Comm c = MPI_Comm_f2c(comm_);
  MPI_Comm_rank(c, &rank_);
  MPI_Comm_size(c, &ranks_);
  if (std::isnan(options_.rebalance_threshold))
    throw std::invalid_argument("distributed simulation: rebalance_threshold is NaN; give the largest rank's particle "
                                "count over the mean to tolerate before new cuts (default 1.01)");
  if (options_.migrate_every < 1)
    throw std::invalid_argument("distributed simulation: migrate_every is " + std::to_string(options_.migrate_every) +
                                "; give the steps between migrations, at least 1 (1: every step; default 20)");
}

template <int D>
SolverContext BasicRankExchange<D>::solver_context() const {
  SolverContext context;
  context.mpi_comm = comm_;
  return context;
}

// Components a scene added after construction are refused before the next step, on every rank alike.
template <int D>
void BasicRankExchange<D>::check(const BasicSimulation<D>& sim) const {
  const SimulationConfig& c = sim.config();
  auto refuse = [](const std::string& what) {
    throw std::invalid_argument("distributed simulation: " + what + " does not run on several ranks yet; run it "
                                "serially (mps::Simulation)");
  };
  const auto periodic = sim.domain().periodic();
  if (std::any_of(periodic.begin(), periodic.end(), [](bool b) { return b; }))
    refuse("a periodic domain (a halo copy would need its periodic image's shift)");
  if (c.implicit_viscosity) refuse("implicit viscosity (its viscous system is solved over all particles at once)");
  if (c.initial_reference_density) refuse("initial_reference_density (a t = 0 mean over the whole domain)");
  if (sim.template find<BasicInitialReferenceDensity<D>>())
    refuse("InitialReferenceDensity (a t = 0 mean over the whole domain)");
}

template <int D>
void BasicRankExchange<D>::distribute(Particles& particles) {
  if (rank_ != 0) particles = Particles{};  // every rank validated the whole scene; rank 0's copy is distributed
  const auto start = Clock::now();
  partition_.emplace(comm_, options_.kind_weights);
  const RcbPartition::Placement placed = partition_->place(particles, options_.rebalance_threshold);
  keep_cut_input(particles);
  stats_.kept_imbalance = stats_.imbalance = stats_.max_imbalance = placed.imbalance;
  count(migrate_particles(particles, placed.destination, comm_));
  stats_.migrate_seconds += seconds_since(start);
}

template <int D>
void BasicRankExchange<D>::count(const ExchangeStats& e) {
  stats_.messages_sent += static_cast<std::size_t>(e.messages_sent);
  stats_.bytes_sent += e.bytes_sent;
}

template <int D>
template <class Field>
void BasicRankExchange<D>::refresh(Field&& field) {
  halo_->refresh(std::forward<Field>(field));
  ++stats_.refreshes;
  count(halo_->last_refresh());
}

template <int D>
void BasicRankExchange<D>::begin_step(Particles& particles, const BasicDomain<D>& domain, double reach,
                                      double cell_size) {
  ++stats_.steps;
  if ((stats_.steps - 1) % static_cast<std::size_t>(options_.migrate_every) == 0)
    migrate_to_partition(particles);
  else
    send_ghosts_home(particles);
  const auto start = Clock::now();
  // Kept in id order, a rank's rows came out of the cell search unsorted and sorting them took about a quarter of a
  // 3-D step (docs/scaling.md).
  if (cell_size > 0.0) {
    BasicCellGrid<D> grid(domain, cell_size);
    grid.bin(particles);
    particles.permute(grid.cell_order());
  }
  halo_radius_ = reach;
  halo_.emplace(particles, domain, halo_radius_, comm_);
  stats_.halo_copies += halo_->copies();
  count(halo_->setup());
  stats_.halo_seconds += seconds_since(start);
}

// The kept cuts' boxes, or new cuts when the load has drifted past the threshold; one migration either way.
template <int D>
void BasicRankExchange<D>::migrate_to_partition(Particles& particles) {
  const auto start = Clock::now();
  ++stats_.placements;
  const RcbPartition::Placement placed = partition_->place(particles, options_.rebalance_threshold);
  const double placing = seconds_since(start);
  if (placed.repartitioned) {
    keep_cut_input(particles);
    ++stats_.repartitions;
    stats_.repartition_seconds += placing;
  } else {
    stats_.assign_seconds += placing;
  }
  stats_.kept_imbalance = placed.kept_imbalance;
  stats_.imbalance = placed.imbalance;
  stats_.max_imbalance = std::max(stats_.max_imbalance, placed.imbalance);
  const ExchangeStats moved = migrate_keeping_order(particles, placed.destination);
  // Told at every placement, as the serial step tells it at every reordering, whether or not a particle moved: a
  // checkpoint then knows that the step after it sets a kept hierarchy up afresh (renumbers_after).
  renumbered_ = true;
  stats_.migrated += moved.particles_sent;
  stats_.migrate_seconds += seconds_since(start);
}

// Between placements only ghosts go to the rank of their box: an outlet parks them beside the inlet, whose plate
// draws its columns from one rank's ghosts (PushingPlate). They are no unknowns: the PPE's rows stay as they were.
template <int D>
void BasicRankExchange<D>::send_ghosts_home(Particles& particles) {
  const auto start = Clock::now();
  std::vector<int> destination(particles.size(), rank_);
  bool any = false;
  for (std::size_t i = 0; i < particles.size(); ++i)
    if (particles.kind[i] == Kind::ghost) {
      destination[i] = partition_->assign<D>(particles.position(i));
      any = any || destination[i] != rank_;
    }
  if (!all(!any)) stats_.ghosts_moved += migrate_keeping_order(particles, destination).particles_sent;
  stats_.migrate_seconds += seconds_since(start);
}

// migrate_particles leaves them by id; those that stayed take back their order, so that the PPE's numbering (and with
// it a reused AMG hierarchy) holds between reorderings as it does serially.
template <int D>
ExchangeStats BasicRankExchange<D>::migrate_keeping_order(Particles& particles, const std::vector<int>& destination) {
  std::vector<std::pair<int, int>> before(particles.size());
  for (std::size_t i = 0; i < particles.size(); ++i) before[i] = {particles.id[i], static_cast<int>(i)};
  std::sort(before.begin(), before.end());
  const ExchangeStats moved = migrate_particles(particles, destination, comm_);
  std::vector<std::pair<long long, int>> key(particles.size());
  auto was = before.begin();
  for (std::size_t i = 0; i < particles.size(); ++i) {  // particles are by id now, as `before` is
    while (was != before.end() && was->first < particles.id[i]) ++was;
    const bool stayed = was != before.end() && was->first == particles.id[i];
    key[i] = {stayed ? was->second : static_cast<long long>(before.size()) + static_cast<long long>(i),
              static_cast<int>(i)};
  }
  std::sort(key.begin(), key.end());
  std::vector<int> order(key.size());
  for (std::size_t i = 0; i < key.size(); ++i) order[i] = key[i].second;
  particles.permute(order);
  count(moved);
  return moved;
}

// A ghost turned fluid after the predictor (a pushing plate's column) was in no halo: its copies join now, and the
// per-particle fields already sized take their owners' entries for them.
template <int D>
void BasicRankExchange<D>::share_predicted(Particles& particles, std::vector<char>& prescribed) {
  const ExchangeStats added = halo_->add_activated(particles);
  stats_.activated_copies += added.particles_received;
  count(added);
  const bool any_added = max(static_cast<double>(added.particles_received)) > 0.0;
  refresh(particles);
  if (!any_added) return;
  prescribed.resize(particles.size(), 0);
  refresh(std::span<char>(prescribed));
}

template <int D>
void BasicRankExchange<D>::share_flags(std::span<char> flags) { refresh(flags); }

template <int D>
PpeCounts BasicRankExchange<D>::assemble(const BasicStencil<D>& laplacian, std::span<const char> held,
                                         std::span<const double> source, std::span<const double> held_value,
                                         double shift, OpenSupport open, PpeRows rows) {
  assemble_distributed_ppe(*halo_, laplacian, held, source, held_value, shift, ppe_, open, rows);
  return {static_cast<std::size_t>(ppe_.solved_rows), ppe_.closed.size()};
}

template <int D>
OwnPpeRows BasicRankExchange<D>::own_rows() const {
  return {ppe_.rhs, std::span<const int>(ppe_.local.particle).first(ppe_.rows())};
}

// Starting from P - offset = 0 sets the owned unknowns' pressures to the offset, which solve_distributed_ppe gathers.
template <int D>
SolveReport BasicRankExchange<D>::solve(LinearSolver& solver, Particles& particles, bool from_zero,
                                        bool clamp_negative, std::span<const double> offset) {
  if (from_zero)
    for (std::size_t r = 0; r < ppe_.rows(); ++r) {
      const auto i = static_cast<std::size_t>(ppe_.local.particle[r]);
      particles.p[i] = offset.empty() ? 0.0 : offset[i];
    }
  if (renumbered_) solver.renumbered();
  renumbered_ = false;
  return solve_distributed_ppe(*halo_, ppe_, solver, particles, clamp_negative, offset);
}

template <int D>
void BasicRankExchange<D>::share_pressure(std::span<double> pressure, std::span<char> carriers) {
  refresh(pressure);
  refresh(carriers);
}

// Shifting moves a particle by its neighbours' positions and velocities at n+1.
template <int D>
void BasicRankExchange<D>::share_particles(Particles& particles) { refresh(particles); }

template <int D>
void BasicRankExchange<D>::end_step(Particles& particles) {
  halo_->remove(particles);
  halo_.reset();
}

template <int D>
void BasicRankExchange<D>::abandon_step() { halo_.reset(); }

template <int D>
std::size_t BasicRankExchange<D>::owned(const Particles& particles) const {
  return halo_ ? halo_->owned() : particles.size();
}

template <int D>
double BasicRankExchange<D>::max(double value) const {
  MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MAX, MPI_Comm_f2c(comm_));
  return value;
}

template <int D>
bool BasicRankExchange<D>::all(bool value) const {
  int v = value;
  MPI_Allreduce(MPI_IN_PLACE, &v, 1, MPI_INT, MPI_LAND, MPI_Comm_f2c(comm_));
  return v != 0;
}

template <int D>
long long BasicRankExchange<D>::sum(long long value) const {
  MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_LONG_LONG, MPI_SUM, MPI_Comm_f2c(comm_));
  return value;
}

template <int D>
std::string BasicRankExchange<D>::first_failure(const std::string& failure) const {
  const MPI_Comm c = MPI_Comm_f2c(comm_);
  int first = failure.empty() ? ranks_ : rank_;
  MPI_Allreduce(MPI_IN_PLACE, &first, 1, MPI_INT, MPI_MIN, c);
  if (first == ranks_) return {};
  std::string reason = failure;
  int length = static_cast<int>(reason.size());
  MPI_Bcast(&length, 1, MPI_INT, first, c);
  reason.resize(static_cast<std::size_t>(length));
  MPI_Bcast(reason.data(), length, MPI_CHAR, first, c);
  return "rank " + std::to_string(first) + " of " + std::to_string(ranks_) + " (particle numbers are that rank's): " +
         reason;
}

template <int D>
typename BasicRankExchange<D>::Particles BasicRankExchange<D>::gather(const Particles& own) const {
  Particles all = own;
  const std::vector<int> to_root(all.size(), 0);
  migrate_particles(all, to_root, comm_);
  return all;
}

template <int D>
void BasicRankExchange<D>::keep_cut_input(const Particles& particles) {
  cut_input_ = Particles{};
  const auto from = particles.positions();
  const auto to = cut_input_.positions();
  for (std::size_t a = 0; a < D; ++a) *to[a] = *from[a];
  cut_input_.id = particles.id;
  cut_input_.kind = particles.kind;
}

template <int D>
nlohmann::json BasicRankExchange<D>::save_state() const {
  nlohmann::json cut = nlohmann::json::object();
  static constexpr const char* names[3] = {"x", "y", "z"};
  const auto r = cut_input_.positions();
  for (std::size_t a = 0; a < D; ++a) cut[names[a]] = pack_array(*r[a]);
  cut["id"] = pack_array(cut_input_.id);
  cut["kind"] = pack_array(cut_input_.kind);
  return {{"steps", stats_.steps}, {"renumbered", renumbered_}, {"cut_input", cut}};
}

template <int D>
void BasicRankExchange<D>::restore_state(const nlohmann::json& state, int steps) {
  if (state.is_null()) {  // particles distributed afresh (another rank count): new cuts, and a setup afresh
    stats_.steps = static_cast<std::size_t>(steps);
    renumbered_ = true;
    return;
  }
  Particles input;
  static constexpr const char* names[3] = {"x", "y", "z"};
  const nlohmann::json& cut = state_part(state, "cut_input");
  const auto r = input.positions();
  for (std::size_t a = 0; a < D; ++a) unpack_array(cut, names[a], *r[a]);
  unpack_array(cut, "id", input.id);
  unpack_array(cut, "kind", input.kind);
  if (input.id.size() != input.size() || input.kind.size() != input.size())
    throw std::runtime_error("checkpoint: the kept cuts' input differs in length (a damaged file?)");
  // The same input on every rank as when the cuts were made gives the same cuts (Zoltan's RCB is deterministic).
  partition_.emplace(comm_, options_.kind_weights);
  (void)partition_->repartition(input);
  cut_input_ = std::move(input);
  stats_.steps = unpack_value<std::size_t>(state, "steps");
  renumbered_ = unpack_value<bool>(state, "renumbered");
}

template <int D>
bool BasicRankExchange<D>::renumbers_after(int steps, const SimulationConfig&) const {
  return steps % options_.migrate_every == 0;
}

template <int D>
nlohmann::json BasicRankExchange<D>::gather_states(nlohmann::json own) const {
  const MPI_Comm c = MPI_Comm_f2c(comm_);
  const std::vector<std::uint8_t> bytes = nlohmann::json::to_cbor(own);
  int size = static_cast<int>(bytes.size());
  std::vector<int> sizes(rank_ == 0 ? static_cast<std::size_t>(ranks_) : 0), offsets(sizes.size() + 1, 0);
  MPI_Gather(&size, 1, MPI_INT, sizes.data(), 1, MPI_INT, 0, c);
  for (std::size_t q = 0; q < sizes.size(); ++q) offsets[q + 1] = offsets[q] + sizes[q];
  std::vector<std::uint8_t> all(rank_ == 0 ? static_cast<std::size_t>(offsets.back()) : 0);
  MPI_Gatherv(bytes.data(), size, MPI_BYTE, all.data(), sizes.data(), offsets.data(), MPI_BYTE, 0, c);
  if (rank_ != 0) return nullptr;
  nlohmann::json parts = nlohmann::json::array();
  for (std::size_t q = 0; q < sizes.size(); ++q)
    parts.push_back(nlohmann::json::from_cbor(all.begin() + offsets[q], all.begin() + offsets[q + 1], true, true,
                                              nlohmann::json::cbor_tag_handler_t::store));
  return {{"ranks", ranks_}, {"parts", std::move(parts)}};
}

template <int D>
const nlohmann::json& BasicRankExchange<D>::own_part(const std::vector<const nlohmann::json*>& parts) const {
  return *parts.at(static_cast<std::size_t>(rank_));
}

template class BasicRankExchange<2>;
template class BasicRankExchange<3>;

}  // namespace mps
