#pragma once
#include <array>
/// \file
/// Particles and the PPE distributed over the ranks of an MPI communicator (issue 27, first slice): a Zoltan RCB
/// partition, migration of whole particles to their owners, a halo of the other ranks' particles near one's own, and
/// the PPE assembled by each rank for the unknowns it owns and solved by hypre on the communicator. docs/scaling.md.
///
/// A communicator is passed as its Fortran handle, MPI_Comm_c2f(comm), so that this header needs no `<mpi.h>` (as
/// SolverContext::mpi_comm). Every function here is collective: all ranks of the communicator call it together.
#include <cstddef>
#include <span>
#include <vector>

#include "mps/core/csr.hpp"
#include "mps/core/neighbors.hpp"
#include "mps/core/particles.hpp"
#include "mps/numerics/operators.hpp"
#include "mps/numerics/ppe.hpp"
#include "mps/solvers/solver.hpp"

namespace mps {

/// What one exchange moved, as seen by the calling rank.
struct ExchangeStats {
  std::size_t particles_sent = 0;      ///< particles (or one field's values) sent to other ranks
  std::size_t particles_received = 0;  ///< particles (or values) received from other ranks
  int messages_sent = 0;               ///< point-to-point messages sent: one per rank with something to send
  int messages_received = 0;           ///< point-to-point messages received
  std::size_t bytes_sent = 0;          ///< payload bytes sent
};

/// The rank each of this rank's particles belongs to: Zoltan's recursive coordinate bisection over all ranks'
/// positions (one part per rank, cuts between particles so that a part is a box). The same particles give the same
/// partition. Throws std::invalid_argument for a negative id and std::runtime_error if MPI is not running or Zoltan
/// fails. A one-off RcbPartition::repartition.
template <int D>
std::vector<int> partition_particles(const BasicParticles<D>& particles, int comm);

/// The load imbalance of a distribution: the largest rank's `load` over the mean of all ranks' (1 when every rank
/// has the same; 1 when all are zero). Collective.
double load_imbalance(std::size_t load, int comm);

/// An RCB partition whose cuts are kept between steps (Zoltan's KEEP_CUTS): repartition() finds new cuts over all
/// ranks' particles; assign() puts particles into the kept boxes without any communication
/// (Zoltan_LB_Point_Assign). Either way a particle's rank is a function of its position and the cuts alone, not of
/// which rank holds it. The load balanced is the sum of the particles' kind weights: by default every kind alike (the
/// particle count); a 3-D tank's wall and dummy layers outnumber its fluid, and weighting them by what they cost
/// keeps the fluid from landing on one rank (docs/scaling.md).
class RcbPartition {
 public:
  /// The load of one particle of each Kind (fluid, wall, dummy, ghost).
  using KindWeights = std::array<double, 4>;
  /// No cuts yet: the first place() or repartition() makes them. Throws std::runtime_error if MPI is not running, and
  /// std::invalid_argument for a weight that is negative or not finite, or all zero.
  explicit RcbPartition(int comm, KindWeights weights = {1.0, 1.0, 1.0, 1.0});
  ~RcbPartition();  ///< frees Zoltan's structure
  RcbPartition(RcbPartition&& other) noexcept;  ///< takes other's Zoltan structure and cuts (other has none after)
  RcbPartition& operator=(RcbPartition&& other) noexcept;  ///< swaps the two (other frees this one's when it goes)
  RcbPartition(const RcbPartition&) = delete;
  RcbPartition& operator=(const RcbPartition&) = delete;

  /// New cuts over every rank's particles and each of this rank's particles' rank under them. Collective. Throws
  /// std::invalid_argument for a negative id, std::runtime_error if Zoltan fails.
  template <int D>
  std::vector<int> repartition(const BasicParticles<D>& particles);
  /// Each particle's rank under the kept cuts. Local. Throws std::logic_error before the first repartition().
  template <int D>
  [[nodiscard]] std::vector<int> assign(const BasicParticles<D>& particles) const;
  /// The rank of the kept box holding point `r`. Local. Throws as assign().
  template <int D>
  [[nodiscard]] int assign(const Vec<D>& r) const;
  [[nodiscard]] bool has_cuts() const { return has_cuts_; }  ///< a repartition() has been made
  [[nodiscard]] int comm() const { return comm_; }            ///< the communicator's Fortran handle

  /// Where each particle goes for the next step, and whether the cuts were renewed for it.
  struct Placement {
    std::vector<int> destination;  ///< this rank's particles' ranks
    double kept_imbalance = 1;     ///< the largest rank's load over the mean under the kept cuts (1: none)
    double imbalance = 1;          ///< the same for `destination`: after the repartition if there was one
    bool repartitioned = false;    ///< new cuts were made (no cuts yet, or kept_imbalance > threshold)
  };
  /// The kept cuts' assignment, or a repartition when there are no cuts yet or the kept cuts would leave the largest
  /// rank more than `threshold` times the mean load (kind weights). Collective (one MPI_Allreduce of P loads, plus the
  /// repartition when made); every rank takes the same decision. A threshold of 1 or below repartitions every
  /// time, +infinity never after the first. Throws std::invalid_argument for a NaN threshold.
  template <int D>
  Placement place(const BasicParticles<D>& particles, double threshold);

 private:
  struct Zoltan;  // the Zoltan_Struct holding the cuts
  template <int D>
  [[nodiscard]] double imbalance_of(const BasicParticles<D>& particles, const std::vector<int>& destination) const;
  int comm_ = 0;
  KindWeights weights_;
  bool has_cuts_ = false;
  Zoltan* zoltan_ = nullptr;
};

/// Sends particle i, every array of it, to rank destination[i]; afterwards this rank holds the particles sent to it,
/// sorted by id (ids are global: a particle keeps its id whichever rank holds it). Particles must hold no halo copies
/// (Halo::remove first). Throws std::invalid_argument for a destination outside the communicator and for an id that
/// arrives twice on one rank.
template <int D>
ExchangeStats migrate_particles(BasicParticles<D>& particles, std::span<const int> destination, int comm);

/// partition_particles, then migrate_particles: each rank ends up owning one RCB box of the particles. A scene may
/// start with all particles on rank 0 and none elsewhere.
template <int D>
ExchangeStats distribute_particles(BasicParticles<D>& particles, int comm);

/// Copies of the other ranks' particles within a radius of this rank's own (the owned ones), appended after them,
/// and the lists to refresh the copies of any per-particle field with one exchange.
///
/// Rank q receives from rank r every non-ghost particle of r inside the bounding box of q's non-ghost particles
/// widened by the radius on every side: each particle closer than the radius to one of q's is among them. The copies
/// come in rank order, each rank's in its own order.
template <int D>
class BasicHalo {
 public:
  /// Appends to `particles` (this rank's owned particles, no copies yet) the halo copies, every array of them.
  /// Throws std::invalid_argument for a periodic domain (not supported yet) or a radius that is not positive.
  BasicHalo(BasicParticles<D>& particles, const BasicDomain<D>& domain, double radius, int comm);

  [[nodiscard]] std::size_t owned() const { return owned_; }     ///< particles this rank owns: indices [0, owned())
  [[nodiscard]] std::size_t copies() const { return copies_; }   ///< halo copies: indices [owned(), owned() + copies())
  [[nodiscard]] double radius() const { return radius_; }        ///< the radius the halo covers [m]
  [[nodiscard]] int comm() const { return comm_; }               ///< the communicator's Fortran handle
  [[nodiscard]] int neighbour_ranks() const;                     ///< ranks this one exchanges with (either way)
  [[nodiscard]] const ExchangeStats& setup() const { return setup_; }  ///< what building the halo moved
  /// What the latest refresh moved (values, messages, bytes).
  [[nodiscard]] const ExchangeStats& last_refresh() const { return last_; }

  /// Overwrites the halo copies' entries of a per-particle field (owned() + copies() entries) with their owners'
  /// values: one message to and from each neighbour rank.
  void refresh(std::span<double> field);
  void refresh(std::span<int> field);   ///< same, for an int field
  void refresh(std::span<char> field);  ///< same, for a flag field
  /// Refreshes every array of the copies (positions, velocities, pressure, kind, group, id) in one exchange.
  void refresh(BasicParticles<D>& particles);
  /// Drops the copies from `particles` (before a migration or a new halo).
  void remove(BasicParticles<D>& particles) const;
  /// Copies, appended after the others, of the owned particles that were ghosts when the halo was built and are not
  /// now (a pushing plate's new column), to the ranks whose box widened by the radius holds them (the boxes of the
  /// halo's construction). Returns what it moved (particles_received: the copies this rank received); later refreshes
  /// include them.
  ExchangeStats add_activated(BasicParticles<D>& particles);

 private:
  struct Link {
    int rank = 0;
    std::vector<int> particles;  // send: owned indices to copy; receive: empty
    std::size_t first = 0, count = 0;  // receive: where the copies sit and how many
  };
  void exchange(void* field, std::size_t value_bytes);
  void check_size(std::size_t size) const;
  // Copies of the `candidates` (owned indices) inside each other rank's box widened by the radius, appended to that
  // rank's particles after its copies so far, with new links after the old (one message per rank pair each way).
  ExchangeStats send_copies(BasicParticles<D>& particles, const std::vector<int>& candidates, int tag);

  int comm_ = 0;
  double radius_ = 0;
  std::size_t owned_ = 0, copies_ = 0;
  std::vector<Link> send_, receive_;
  std::vector<double> boxes_;   // every rank's box of its non-ghost particles at construction: min, max by axis
  std::vector<int> ghosts_;     // owned particles that were ghosts at construction and have not been sent since
  ExchangeStats setup_, last_;
};
using Halo = BasicHalo<2>;   ///< the 2-D halo
using Halo3 = BasicHalo<3>;  ///< the 3-D halo

/// The PPE over the particles of every rank, each rank holding the rows of the unknowns it owns. Global unknown
/// numbers: rank 0's unknowns first, in its particles' order, then rank 1's, and so on.
struct DistributedPpe {
  /// assemble_ppe over this rank's owned and halo particles, closed groups left ungauged; its first rows() unknowns
  /// are the owned ones (owned particles come first)
  PpeSystem local;
  CsrMatrix matrix;          ///< this rank's rows with global column numbers (matrix.cols: the global size)
  std::vector<double> rhs;   ///< their right-hand side, each closed group's mean taken out
  long long first_row = 0;   ///< the global number of this rank's first row
  long long global_rows = 0; ///< rows over all ranks
  long long solved_rows = 0; ///< rows over all ranks that are solved for: global_rows less the held rows
  std::vector<int> global;   ///< local unknown (owned or halo) -> global unknown number
  std::vector<int> group;    ///< row -> index into closed, or -1 when a free surface anchors it
  /// Every group of unknowns no free surface anchors, over all ranks (the same list on every rank): `pinned` is the
  /// global number of the member whose diagonal was doubled (the lowest), `size` and `removed_rhs_mean` are global.
  std::vector<FloatingGroup> closed;

  [[nodiscard]] std::size_t rows() const { return rhs.size(); }  ///< unknowns this rank owns
};

/// Assembles the distributed PPE: `laplacian` over this rank's owned and halo particles (the neighbour list covering
/// them, its radius within the halo's); `free_surface`, `source` and `dirichlet` have one entry per particle, owned
/// and halo (the halo entries are ignored and refreshed here from their owners). A group closed across ranks gets
/// the gauge assemble_ppe gives a closed group on one rank (the zero-mean solution), found by joining each rank's
/// connected pieces through the halo on rank 0. Throws std::invalid_argument when the halo is narrower than the
/// kernel or the sizes do not match.
template <int D>
DistributedPpe assemble_distributed_ppe(BasicHalo<D>& halo, const BasicStencil<D>& laplacian, std::span<const char> free_surface,
                                        std::span<const double> source, std::span<const double> dirichlet = {},
                                        double shift = 0.0);
/// The same into `into`, whose vectors keep their memory from one step to the next (a step's PPE at 1e6 particles is
/// about a gigabyte that would otherwise come back from the kernel as fresh pages each step); `open` and `rows` as
/// assemble_ppe's (the halo's entries refreshed likewise). With PpeRows::every_particle each rank holds a row for each
/// fluid and wall particle it owns, so the numbering holds between migrations however the free surface moves.
template <int D>
void assemble_distributed_ppe(BasicHalo<D>& halo, const BasicStencil<D>& laplacian, std::span<const char> free_surface,
                              std::span<const double> source, std::span<const double> dirichlet, double shift,
                              DistributedPpe& into, OpenSupport open = {}, PpeRows rows = PpeRows::unknowns);

/// Solves the distributed PPE with `solver` (made with SolverContext::mpi_comm = the halo's communicator: hypre-pcg,
/// hypre-amg or auto), warm-started from the particles' pressures, and writes the pressures as PpeSystem::scatter
/// does (closed groups shifted to zero mean over all ranks; `clamp_negative`, `offset` likewise), then refreshes the
/// halo copies' pressures.
template <int D>
SolveReport solve_distributed_ppe(BasicHalo<D>& halo, const DistributedPpe& ppe, LinearSolver& solver,
                                  BasicParticles<D>& particles,
                                  bool clamp_negative = false, std::span<const double> offset = {});

}  // namespace mps
