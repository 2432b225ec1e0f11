#include "mps/parallel/distributed.hpp"

#include <mpi.h>
#include <zoltan.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <iterator>
#include <limits>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>

namespace mps {
namespace {

MPI_Comm to_comm(int fortran) { return MPI_Comm_f2c(fortran); }

void require_mpi(const char* what) {
  int initialised = 0, finalized = 0;
  MPI_Initialized(&initialised);
  MPI_Finalized(&finalized);
  if (!initialised || finalized)
    throw std::runtime_error(std::string(what) + ": MPI is not running; call it between MPI_Init and MPI_Finalize");
}

int rank_of(MPI_Comm comm) {
  int r = 0;
  MPI_Comm_rank(comm, &r);
  return r;
}
int size_of(MPI_Comm comm) {
  int s = 1;
  MPI_Comm_size(comm, &s);
  return s;
}

// One particle, every array of its field list (BasicParticles::for_each_field), as the bytes a message carries.
template <int D>
class Record {
 public:
  Record() {
    BasicParticles<D> probe;
    probe.for_each_field([&](const char* name, const auto& field) {
      if (std::string(name) == "id") id_at_ = bytes_;
      bytes_ += sizeof(field[0]);
    });
  }
  [[nodiscard]] std::size_t bytes() const { return bytes_; }
  void pack(const BasicParticles<D>& s, std::size_t i, unsigned char* out) const {
    s.for_each_field([&](const char*, const auto& field) {
      std::memcpy(out, &field[i], sizeof(field[i]));
      out += sizeof(field[i]);
    });
  }
  void unpack(const unsigned char* in, BasicParticles<D>& s, std::size_t i) const {
    s.for_each_field([&](const char*, auto& field) {
      std::memcpy(&field[i], in, sizeof(field[i]));
      in += sizeof(field[i]);
    });
  }
  [[nodiscard]] int id(const unsigned char* record) const {
    int value = 0;
    std::memcpy(&value, record + id_at_, sizeof value);
    return value;
  }

 private:
  std::size_t bytes_ = 0, id_at_ = 0;
};

template <int D>
void resize(BasicParticles<D>& s, std::size_t n) {
  s.for_each_field([n](const char*, auto& field) { field.resize(n); });
}

// Zoltan's query functions over one rank's particles: their ids and coordinates.
struct ZoltanInput {
  std::size_t count = 0;
  const int* ids = nullptr;
  const Kind* kinds = nullptr;
  std::array<double, 4> weights{};
  int dim = 2;
  std::array<const double*, 3> coords{};
};
template <int D>
void set_input(ZoltanInput& in, const BasicParticles<D>& particles, const std::array<double, 4>& weights) {
  in.count = particles.size();
  in.ids = particles.id.data();
  in.kinds = particles.kind.data();
  in.weights = weights;
  in.dim = D;
  for (std::size_t a = 0; a < D; ++a) in.coords[a] = particles.positions()[a]->data();
}
int zoltan_count(void* data, int* ierr) {
  *ierr = ZOLTAN_OK;
  return static_cast<int>(static_cast<ZoltanInput*>(data)->count);
}
void zoltan_objects(void* data, int, int, ZOLTAN_ID_PTR global, ZOLTAN_ID_PTR local, int weight_dim, float* weight,
                    int* ierr) {
  const ZoltanInput& s = *static_cast<ZoltanInput*>(data);
  for (std::size_t i = 0; i < s.count; ++i) {
    global[i] = static_cast<ZOLTAN_ID_TYPE>(s.ids[i]);
    local[i] = static_cast<ZOLTAN_ID_TYPE>(i);
    if (weight_dim == 1) weight[i] = static_cast<float>(s.weights[static_cast<std::size_t>(s.kinds[i])]);
  }
  *ierr = ZOLTAN_OK;
}
int zoltan_dimension(void* data, int* ierr) {
  *ierr = ZOLTAN_OK;
  return static_cast<ZoltanInput*>(data)->dim;
}
void zoltan_positions(void* data, int, int, int count, ZOLTAN_ID_PTR, ZOLTAN_ID_PTR local, int dim, double* xyz,
                      int* ierr) {
  const ZoltanInput& s = *static_cast<ZoltanInput*>(data);
  for (int k = 0; k < count; ++k)
    for (int a = 0; a < dim; ++a)
      xyz[dim * k + a] = s.coords[static_cast<std::size_t>(a)][static_cast<std::size_t>(local[k])];
  *ierr = ZOLTAN_OK;
}

// The union-find of connected groups (as in ppe.cpp's gauge).
int find_root(std::vector<int>& parent, int a) {
  while (parent[static_cast<std::size_t>(a)] != a) {
    parent[static_cast<std::size_t>(a)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(a)])];
    a = parent[static_cast<std::size_t>(a)];
  }
  return a;
}
void join(std::vector<int>& parent, int a, int b) {
  a = find_root(parent, a);
  b = find_root(parent, b);
  if (a != b) parent[static_cast<std::size_t>(std::max(a, b))] = std::min(a, b);
}

}  // namespace

template <int D>
std::vector<int> partition_particles(const BasicParticles<D>& particles, int comm) {
  RcbPartition partition(comm);
  return partition.repartition(particles);
}

double load_imbalance(std::size_t load, int comm_handle) {
  require_mpi("load_imbalance");
  const MPI_Comm comm = to_comm(comm_handle);
  unsigned long long largest = load, sum = load;
  MPI_Allreduce(MPI_IN_PLACE, &largest, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, comm);
  MPI_Allreduce(MPI_IN_PLACE, &sum, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, comm);
  if (sum == 0) return 1.0;
  return static_cast<double>(largest) * size_of(comm) / static_cast<double>(sum);
}

struct RcbPartition::Zoltan {
  Zoltan_Struct* zz = nullptr;
  ZoltanInput input;
  int dim = 0;  // of the particles it partitions (fixed at the first repartition)
};

namespace {
bool every_kind_alike(const RcbPartition::KindWeights& w) {
  return std::all_of(w.begin(), w.end(), [&](double x) { return x == w[0]; });
}
}  // namespace

RcbPartition::RcbPartition(int comm_handle, KindWeights weights) : comm_(comm_handle), weights_(weights) {
  require_mpi("RcbPartition");
  for (double w : weights_)
    if (!(w >= 0.0 && std::isfinite(w)))
      throw std::invalid_argument("RcbPartition: a kind's load weight must be finite and >= 0, got " +
                                  std::to_string(w));
  if (weights_[0] == 0.0 && every_kind_alike(weights_))
    throw std::invalid_argument("RcbPartition: every kind's load weight is 0; give the fluid a positive weight");
}

RcbPartition::~RcbPartition() {
  if (zoltan_ == nullptr) return;
  // Zoltan_Destroy frees its communicator: only while MPI runs (a partition outliving MPI_Finalize leaks instead).
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (!finalized) Zoltan_Destroy(&zoltan_->zz);
  delete zoltan_;
}

RcbPartition::RcbPartition(RcbPartition&& other) noexcept
    : comm_(other.comm_), weights_(other.weights_), has_cuts_(std::exchange(other.has_cuts_, false)),
      zoltan_(std::exchange(other.zoltan_, nullptr)) {}

RcbPartition& RcbPartition::operator=(RcbPartition&& other) noexcept {
  std::swap(comm_, other.comm_);
  std::swap(weights_, other.weights_);
  std::swap(has_cuts_, other.has_cuts_);
  std::swap(zoltan_, other.zoltan_);
  return *this;
}

template <int D>
std::vector<int> RcbPartition::repartition(const BasicParticles<D>& particles) {
  for (int id : particles.id)
    if (id < 0)
      throw std::invalid_argument("partition_particles: particle id " + std::to_string(id) +
                                  " is negative; ids must be the global numbers Particles::add gives");
  static std::once_flag once;
  std::call_once(once, [] {
    float version = 0;
    if (Zoltan_Initialize(0, nullptr, &version) != ZOLTAN_OK) throw std::runtime_error("Zoltan_Initialize failed");
  });
  if (zoltan_ == nullptr) {
    Zoltan_Struct* zz = Zoltan_Create(to_comm(comm_));
    if (zz == nullptr) throw std::runtime_error("partition_particles: Zoltan_Create failed");
    zoltan_ = new Zoltan{zz, {}, D};
    // RCB, one part per rank; rectilinear blocks keep every particle on a cut line on one side, so the partition is
    // a function of the positions alone (a lattice has many particles on each line). The cuts are kept for assign().
    // No remapping of parts to the ranks holding most of their particles: on 3 ranks that gave the same boxes other
    // ranks depending on who held what.
    const char* params[][2] = {{"DEBUG_LEVEL", "0"},          {"LB_METHOD", "RCB"},
                               {"NUM_GID_ENTRIES", "1"},      {"NUM_LID_ENTRIES", "1"},
                               {"OBJ_WEIGHT_DIM", every_kind_alike(weights_) ? "0" : "1"},
                               {"RETURN_LISTS", "NONE"},
                               {"RCB_RECTILINEAR_BLOCKS", "1"}, {"KEEP_CUTS", "1"},
                               {"REMAP", "0"},                {"IMBALANCE_TOL", "1.05"}};
    for (const auto& kv : params) Zoltan_Set_Param(zz, kv[0], kv[1]);
    Zoltan_Set_Num_Obj_Fn(zz, zoltan_count, &zoltan_->input);
    Zoltan_Set_Obj_List_Fn(zz, zoltan_objects, &zoltan_->input);
    Zoltan_Set_Num_Geom_Fn(zz, zoltan_dimension, &zoltan_->input);
    Zoltan_Set_Geom_Multi_Fn(zz, zoltan_positions, &zoltan_->input);
  }
  if (zoltan_->dim != D)
    throw std::invalid_argument("RcbPartition: cut for " + std::to_string(zoltan_->dim) + "-D particles, given " +
                                std::to_string(D) + "-D ones");
  set_input(zoltan_->input, particles, weights_);
  int changes = 0, gid_entries = 0, lid_entries = 0, imports = 0, exports = 0;
  ZOLTAN_ID_PTR import_gid = nullptr, import_lid = nullptr, export_gid = nullptr, export_lid = nullptr;
  int *import_procs = nullptr, *import_parts = nullptr, *export_procs = nullptr, *export_parts = nullptr;
  const int code = Zoltan_LB_Partition(zoltan_->zz, &changes, &gid_entries, &lid_entries, &imports, &import_gid,
                                       &import_lid, &import_procs, &import_parts, &exports, &export_gid, &export_lid,
                                       &export_procs, &export_parts);
  Zoltan_LB_Free_Part(&import_gid, &import_lid, &import_procs, &import_parts);
  Zoltan_LB_Free_Part(&export_gid, &export_lid, &export_procs, &export_parts);
  zoltan_->input = {};
  if (code != ZOLTAN_OK) throw std::runtime_error("partition_particles: Zoltan_LB_Partition failed");
  has_cuts_ = true;
  // The ranks from the cuts (not from Zoltan's export lists): the same rule assign() applies on later steps.
  return assign(particles);
}

template <int D>
std::vector<int> RcbPartition::assign(const BasicParticles<D>& particles) const {
  if (!has_cuts_)
    throw std::logic_error("RcbPartition::assign: no cuts yet; call repartition() (or place()) first");
  if (zoltan_->dim != D)
    throw std::invalid_argument("RcbPartition: cut for " + std::to_string(zoltan_->dim) + "-D particles, given " +
                                std::to_string(D) + "-D ones");
  std::vector<int> destination(particles.size());
  for (std::size_t i = 0; i < particles.size(); ++i) destination[i] = assign<D>(particles.position(i));
  return destination;
}

template <int D>
int RcbPartition::assign(const Vec<D>& r) const {
  if (!has_cuts_)
    throw std::logic_error("RcbPartition::assign: no cuts yet; call repartition() (or place()) first");
  if (zoltan_->dim != D)
    throw std::invalid_argument("RcbPartition: cut for " + std::to_string(zoltan_->dim) + "-D particles, given a " +
                                std::to_string(D) + "-D point");
  Vec<D> point = r;  // Zoltan takes a non-const pointer
  int rank = 0;
  if (Zoltan_LB_Point_Assign(zoltan_->zz, point.data(), &rank) != ZOLTAN_OK)
    throw std::runtime_error("RcbPartition::assign: Zoltan_LB_Point_Assign failed");
  return rank;
}

template <int D>
double RcbPartition::imbalance_of(const BasicParticles<D>& particles, const std::vector<int>& destination) const {
  const MPI_Comm comm = to_comm(comm_);
  if (every_kind_alike(weights_)) {  // the particle count, exactly
    std::vector<unsigned long long> count(static_cast<std::size_t>(size_of(comm)), 0);
    for (int d : destination) ++count[static_cast<std::size_t>(d)];
    MPI_Allreduce(MPI_IN_PLACE, count.data(), static_cast<int>(count.size()), MPI_UNSIGNED_LONG_LONG, MPI_SUM, comm);
    const unsigned long long sum = std::accumulate(count.begin(), count.end(), 0ULL);
    if (sum == 0) return 1.0;
    return static_cast<double>(*std::max_element(count.begin(), count.end())) * static_cast<double>(count.size()) /
           static_cast<double>(sum);
  }
  std::vector<double> load(static_cast<std::size_t>(size_of(comm)), 0.0);
  for (std::size_t i = 0; i < destination.size(); ++i)
    load[static_cast<std::size_t>(destination[i])] += weights_[static_cast<std::size_t>(particles.kind[i])];
  MPI_Allreduce(MPI_IN_PLACE, load.data(), static_cast<int>(load.size()), MPI_DOUBLE, MPI_SUM, comm);
  const double sum = std::accumulate(load.begin(), load.end(), 0.0);
  if (sum == 0.0) return 1.0;
  return *std::max_element(load.begin(), load.end()) * static_cast<double>(load.size()) / sum;
}

template <int D>
RcbPartition::Placement RcbPartition::place(const BasicParticles<D>& particles, double threshold) {
  if (std::isnan(threshold))
    throw std::invalid_argument("RcbPartition::place: the rebalance threshold is NaN; give the largest load over the "
                                "mean to tolerate, e.g. 1.1");
  Placement out;
  if (has_cuts_) {
    out.destination = assign(particles);
    out.kept_imbalance = out.imbalance = imbalance_of(particles, out.destination);
    if (out.kept_imbalance <= threshold && threshold > 1.0) return out;
  }
  out.destination = repartition(particles);
  out.imbalance = imbalance_of(particles, out.destination);
  out.repartitioned = true;
  return out;
}

template <int D>
ExchangeStats migrate_particles(BasicParticles<D>& particles, std::span<const int> destination, int comm_handle) {
  require_mpi("migrate_particles");
  const MPI_Comm comm = to_comm(comm_handle);
  const int ranks = size_of(comm), me = rank_of(comm);
  const std::size_t n = particles.size();
  if (destination.size() != n)
    throw std::invalid_argument("migrate_particles: " + std::to_string(destination.size()) + " destinations for " +
                                std::to_string(n) + " particles; give one per particle");
  for (int d : destination)
    if (d < 0 || d >= ranks)
      throw std::invalid_argument("migrate_particles: destination rank " + std::to_string(d) +
                                  " outside the communicator's " + std::to_string(ranks) + " ranks");
  // Records grouped by destination (counting sort keeps each rank's particles in their order).
  std::vector<int> send_count(static_cast<std::size_t>(ranks), 0), receive_count(send_count.size(), 0);
  for (int d : destination) ++send_count[static_cast<std::size_t>(d)];
  std::vector<int> send_offset(send_count.size() + 1, 0);
  for (std::size_t q = 0; q < send_count.size(); ++q) send_offset[q + 1] = send_offset[q] + send_count[q];
  const Record<D> record;
  const std::size_t bytes = record.bytes();
  std::vector<unsigned char> out(n * bytes);
  {
    std::vector<int> next(send_offset.begin(), send_offset.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      record.pack(particles, i, out.data() + bytes * static_cast<std::size_t>(next[static_cast<std::size_t>(destination[i])]++));
  }
  MPI_Alltoall(send_count.data(), 1, MPI_INT, receive_count.data(), 1, MPI_INT, comm);
  std::vector<int> receive_offset(receive_count.size() + 1, 0);
  for (std::size_t q = 0; q < receive_count.size(); ++q)
    receive_offset[q + 1] = receive_offset[q] + receive_count[q];
  std::vector<unsigned char> in(static_cast<std::size_t>(receive_offset.back()) * bytes);

  ExchangeStats stats;
  // Point to point with the ranks that have something to exchange: the messages counted are the messages sent.
  std::vector<MPI_Request> requests;
  constexpr int tag = 2701;
  const auto record_bytes = static_cast<int>(bytes);
  for (int q = 0; q < ranks; ++q) {
    const auto u = static_cast<std::size_t>(q);
    if (q == me || receive_count[u] == 0) continue;
    requests.emplace_back();
    MPI_Irecv(in.data() + static_cast<std::size_t>(receive_offset[u]) * bytes, receive_count[u] * record_bytes, MPI_BYTE,
              q, tag, comm, &requests.back());
    ++stats.messages_received;
    stats.particles_received += static_cast<std::size_t>(receive_count[u]);
  }
  for (int q = 0; q < ranks; ++q) {
    const auto u = static_cast<std::size_t>(q);
    if (q == me || send_count[u] == 0) continue;
    requests.emplace_back();
    MPI_Isend(out.data() + static_cast<std::size_t>(send_offset[u]) * bytes, send_count[u] * record_bytes, MPI_BYTE,
              q, tag, comm, &requests.back());
    ++stats.messages_sent;
    stats.particles_sent += static_cast<std::size_t>(send_count[u]);
    stats.bytes_sent += static_cast<std::size_t>(send_count[u]) * bytes;
  }
  const auto mine = static_cast<std::size_t>(me);
  std::copy(out.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(send_offset[mine]) * bytes),
            out.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(send_offset[mine + 1]) * bytes),
            in.begin() + static_cast<std::ptrdiff_t>(static_cast<std::size_t>(receive_offset[mine]) * bytes));
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);

  // Owned particles by id: the order, like the ids, is then the same whatever the rank count.
  const std::size_t received = in.size() / bytes;
  std::vector<std::pair<int, std::size_t>> by_id(received);
  for (std::size_t k = 0; k < received; ++k) by_id[k] = {record.id(in.data() + k * bytes), k};
  std::sort(by_id.begin(), by_id.end());
  for (std::size_t k = 1; k < received; ++k)
    if (by_id[k].first == by_id[k - 1].first)
      throw std::invalid_argument("migrate_particles: particle id " + std::to_string(by_id[k].first) +
                                  " arrived twice on rank " + std::to_string(me) +
                                  "; ids must be unique (renumber merged particle sets)");
  resize(particles, received);
  for (std::size_t k = 0; k < received; ++k) record.unpack(in.data() + by_id[k].second * bytes, particles, k);
  return stats;
}

template <int D>
ExchangeStats distribute_particles(BasicParticles<D>& particles, int comm) {
  const std::vector<int> destination = partition_particles(particles, comm);
  return migrate_particles(particles, destination, comm);
}

// ---------------------------------------------------------------------------------------------------------------------

template <int D>
BasicHalo<D>::BasicHalo(BasicParticles<D>& particles, const BasicDomain<D>& domain, double radius, int comm_handle)
    : comm_(comm_handle), radius_(radius), owned_(particles.size()) {
  require_mpi("Halo");
  const auto periodic = domain.periodic();
  if (std::any_of(periodic.begin(), periodic.end(), [](bool b) { return b; }))
    throw std::invalid_argument("Halo: periodic domains are not supported yet (a copy would need its periodic image); "
                                "distribute a scene with closed boundaries");
  if (!(radius > 0.0) || !std::isfinite(radius))
    throw std::invalid_argument("Halo: the radius must be positive, got " + std::to_string(radius) +
                                " (give the largest kernel radius)");
  const MPI_Comm comm = to_comm(comm_);
  const int ranks = size_of(comm);
  // Each rank's bounding box of its active particles (min, max per axis); an empty one stays inverted and catches
  // nothing.
  constexpr double inf = std::numeric_limits<double>::infinity();
  std::array<double, 2 * D> box;
  for (std::size_t a = 0; a < D; ++a) box[2 * a] = inf, box[2 * a + 1] = -inf;
  for (std::size_t i = 0; i < owned_; ++i) {
    if (particles.kind[i] == Kind::ghost) continue;
    const Vec<D> r = particles.position(i);
    for (std::size_t a = 0; a < D; ++a) {
      box[2 * a] = std::min(box[2 * a], r[a]);
      box[2 * a + 1] = std::max(box[2 * a + 1], r[a]);
    }
  }
  std::vector<double>& boxes = boxes_;
  boxes.resize(2 * D * static_cast<std::size_t>(ranks));
  MPI_Allgather(box.data(), 2 * D, MPI_DOUBLE, boxes.data(), 2 * D, MPI_DOUBLE, comm);
  std::vector<int> active;
  for (std::size_t i = 0; i < owned_; ++i)
    (particles.kind[i] == Kind::ghost ? ghosts_ : active).push_back(static_cast<int>(i));
  // The copies themselves, whole particles, in one message per neighbour rank.
  setup_ = send_copies(particles, active, 2702);
  last_ = setup_;
}

template <int D>
ExchangeStats BasicHalo<D>::send_copies(BasicParticles<D>& particles, const std::vector<int>& candidates, int tag) {
  const MPI_Comm comm = to_comm(comm_);
  const int ranks = size_of(comm), me = rank_of(comm);
  std::vector<int> send_count(static_cast<std::size_t>(ranks), 0), receive_count(send_count.size(), 0);
  std::vector<Link> sends;
  for (int q = 0; q < ranks; ++q) {
    if (q == me) continue;
    const double* b = boxes_.data() + 2 * D * static_cast<std::size_t>(q);
    Link link{q, {}, 0, 0};
    for (int i : candidates) {
      const Vec<D> r = particles.position(static_cast<std::size_t>(i));
      bool near = true;
      for (std::size_t a = 0; a < D; ++a) near = near && r[a] >= b[2 * a] - radius_ && r[a] <= b[2 * a + 1] + radius_;
      if (near) link.particles.push_back(i);
    }
    send_count[static_cast<std::size_t>(q)] = static_cast<int>(link.particles.size());
    if (!link.particles.empty()) sends.push_back(std::move(link));
  }
  MPI_Alltoall(send_count.data(), 1, MPI_INT, receive_count.data(), 1, MPI_INT, comm);
  const std::size_t before = owned_ + copies_;
  std::size_t next = before;
  std::vector<Link> receives;
  for (int q = 0; q < ranks; ++q) {
    const auto c = static_cast<std::size_t>(receive_count[static_cast<std::size_t>(q)]);
    if (c == 0) continue;
    receives.push_back({q, {}, next, c});
    next += c;
  }
  ExchangeStats stats;
  const Record<D> record;
  const std::size_t bytes = record.bytes();
  std::vector<std::vector<unsigned char>> out(sends.size());
  std::vector<unsigned char> in((next - before) * bytes);
  std::vector<MPI_Request> requests;
  for (const Link& link : receives) {
    requests.emplace_back();
    MPI_Irecv(in.data() + (link.first - before) * bytes, static_cast<int>(link.count * bytes), MPI_BYTE, link.rank, tag,
              comm, &requests.back());
    ++stats.messages_received;
    stats.particles_received += link.count;
  }
  for (std::size_t k = 0; k < sends.size(); ++k) {
    out[k].resize(sends[k].particles.size() * bytes);
    for (std::size_t m = 0; m < sends[k].particles.size(); ++m)
      record.pack(particles, static_cast<std::size_t>(sends[k].particles[m]), out[k].data() + m * bytes);
    requests.emplace_back();
    MPI_Isend(out[k].data(), static_cast<int>(out[k].size()), MPI_BYTE, sends[k].rank, tag, comm, &requests.back());
    ++stats.messages_sent;
    stats.particles_sent += sends[k].particles.size();
    stats.bytes_sent += out[k].size();
  }
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
  resize(particles, next);
  for (std::size_t k = 0; k < next - before; ++k) record.unpack(in.data() + k * bytes, particles, before + k);
  copies_ = next - owned_;
  send_.insert(send_.end(), std::make_move_iterator(sends.begin()), std::make_move_iterator(sends.end()));
  receive_.insert(receive_.end(), receives.begin(), receives.end());
  return stats;
}

template <int D>
int BasicHalo<D>::neighbour_ranks() const {
  std::vector<int> ranks;
  for (const Link& l : send_) ranks.push_back(l.rank);
  for (const Link& l : receive_) ranks.push_back(l.rank);
  std::sort(ranks.begin(), ranks.end());
  return static_cast<int>(std::unique(ranks.begin(), ranks.end()) - ranks.begin());
}

template <int D>
void BasicHalo<D>::check_size(std::size_t size) const {
  if (size != owned_ + copies_)
    throw std::invalid_argument("Halo::refresh: the field has " + std::to_string(size) + " entries, the particles " +
                                std::to_string(owned_) + " owned + " + std::to_string(copies_) +
                                " halo copies; give one entry per particle, halo included");
}

template <int D>
void BasicHalo<D>::exchange(void* field, std::size_t value_bytes) {
  const MPI_Comm comm = to_comm(comm_);
  auto* bytes = static_cast<unsigned char*>(field);
  last_ = {};
  std::vector<std::vector<unsigned char>> out(send_.size());
  std::vector<MPI_Request> requests;
  constexpr int tag = 2703;
  for (const Link& link : receive_) {
    requests.emplace_back();
    MPI_Irecv(bytes + link.first * value_bytes, static_cast<int>(link.count * value_bytes), MPI_BYTE, link.rank, tag,
              comm, &requests.back());
    ++last_.messages_received;
    last_.particles_received += link.count;
  }
  for (std::size_t k = 0; k < send_.size(); ++k) {
    out[k].resize(send_[k].particles.size() * value_bytes);
    for (std::size_t m = 0; m < send_[k].particles.size(); ++m)
      std::memcpy(out[k].data() + m * value_bytes, bytes + static_cast<std::size_t>(send_[k].particles[m]) * value_bytes,
                  value_bytes);
    requests.emplace_back();
    MPI_Isend(out[k].data(), static_cast<int>(out[k].size()), MPI_BYTE, send_[k].rank, tag, comm, &requests.back());
    ++last_.messages_sent;
    last_.particles_sent += send_[k].particles.size();
    last_.bytes_sent += out[k].size();
  }
  MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
}

template <int D>
void BasicHalo<D>::refresh(std::span<double> field) {
  check_size(field.size());
  exchange(field.data(), sizeof(double));
}
template <int D>
void BasicHalo<D>::refresh(std::span<int> field) {
  check_size(field.size());
  exchange(field.data(), sizeof(int));
}
template <int D>
void BasicHalo<D>::refresh(std::span<char> field) {
  check_size(field.size());
  exchange(field.data(), sizeof(char));
}

template <int D>
void BasicHalo<D>::refresh(BasicParticles<D>& particles) {
  check_size(particles.size());
  const Record<D> record;
  const std::size_t bytes = record.bytes();
  std::vector<unsigned char> records(particles.size() * bytes);
  for (std::size_t i = 0; i < owned_; ++i) record.pack(particles, i, records.data() + i * bytes);
  exchange(records.data(), bytes);
  for (std::size_t i = owned_; i < particles.size(); ++i) record.unpack(records.data() + i * bytes, particles, i);
}

template <int D>
void BasicHalo<D>::remove(BasicParticles<D>& particles) const {
  check_size(particles.size());
  resize(particles, owned_);
}

// New links, each after the earlier ones to the same rank: both sides post their messages in link order, and MPI keeps
// the order of messages between two ranks, so refreshes match them as they match the first.
template <int D>
ExchangeStats BasicHalo<D>::add_activated(BasicParticles<D>& particles) {
  check_size(particles.size());
  std::vector<int> activated;
  std::erase_if(ghosts_, [&](int i) {
    if (particles.kind[static_cast<std::size_t>(i)] == Kind::ghost) return false;
    activated.push_back(i);
    return true;
  });
  return send_copies(particles, activated, 2704);
}

// ---------------------------------------------------------------------------------------------------------------------

template <int D>
DistributedPpe assemble_distributed_ppe(BasicHalo<D>& halo, const BasicStencil<D>& s, std::span<const char> free_surface,
                                        std::span<const double> source, std::span<const double> dirichlet,
                                        double shift) {
  DistributedPpe d;
  assemble_distributed_ppe(halo, s, free_surface, source, dirichlet, shift, d);
  return d;
}

namespace {

// The owned rows with global numbers: rank by rank in order, the halo's columns numbered by their owners (one refresh
// of an int field), each row's columns sorted.
template <int D>
void number_globally(BasicHalo<D>& halo, std::size_t rows, DistributedPpe& d) {
  const MPI_Comm comm = to_comm(halo.comm());
  const int me = rank_of(comm);
  const PpeSystem& sys = d.local;
  const std::size_t m = sys.size(), n = halo.owned() + halo.copies();
  long long local_rows = static_cast<long long>(rows), first = 0, total = 0;
  MPI_Exscan(&local_rows, &first, 1, MPI_LONG_LONG, MPI_SUM, comm);
  if (me == 0) first = 0;
  MPI_Allreduce(&local_rows, &total, 1, MPI_LONG_LONG, MPI_SUM, comm);
  if (total > std::numeric_limits<int>::max())
    throw std::invalid_argument("assemble_distributed_ppe: more than 2^31 unknowns (CsrMatrix numbers them with int)");
  d.first_row = first;
  d.global_rows = total;

  // Global numbers of the halo's unknowns: their owners' numbers, by one refresh of an int field.
  std::vector<int> number(n, -1);
  for (std::size_t r = 0; r < rows; ++r) number[static_cast<std::size_t>(sys.particle[r])] = static_cast<int>(first) + static_cast<int>(r);
  halo.refresh(number);
  d.global.resize(m);
  for (std::size_t r = 0; r < m; ++r) d.global[r] = number[static_cast<std::size_t>(sys.particle[r])];

  CsrMatrix& a = d.matrix;
  a.rows = static_cast<int>(rows);
  a.cols = static_cast<int>(total);
  a.row_ptr.assign(sys.matrix.row_ptr.begin(), sys.matrix.row_ptr.begin() + static_cast<std::ptrdiff_t>(rows) + 1);
  const auto entries = static_cast<std::size_t>(a.row_ptr.back());
  a.col.resize(entries);
  a.val.assign(sys.matrix.val.begin(), sys.matrix.val.begin() + static_cast<std::ptrdiff_t>(entries));
  for (std::size_t k = 0; k < entries; ++k) {
    const int g = d.global[static_cast<std::size_t>(sys.matrix.col[k])];
    // A column an owned row couples to is an unknown to its owner too (it has a coupled neighbour: this row).
    if (g < 0)
      throw std::logic_error("assemble_distributed_ppe: a halo unknown has no global number (halo out of date?)");
    a.col[k] = g;
  }
  // Sorted columns, as CsrMatrix wants them: halo numbers interleave with owned ones, in the rows that reach a halo.
  std::vector<std::pair<int, double>> row;
  for (std::size_t r = 0; r < rows; ++r) {
    const auto b = static_cast<std::size_t>(a.row_ptr[r]), e = static_cast<std::size_t>(a.row_ptr[r + 1]);
    if (std::is_sorted(a.col.begin() + static_cast<std::ptrdiff_t>(b), a.col.begin() + static_cast<std::ptrdiff_t>(e)))
      continue;
    row.clear();
    for (std::size_t k = b; k < e; ++k) row.emplace_back(a.col[k], a.val[k]);
    std::sort(row.begin(), row.end());
    for (std::size_t k = b; k < e; ++k) std::tie(a.col[k], a.val[k]) = row[k - b];
  }
  d.rhs.assign(sys.rhs.begin(), sys.rhs.begin() + static_cast<std::ptrdiff_t>(rows));
}

// Closed groups across ranks: each owned row's group (-1 where a free surface anchors it) and the number of groups.
// Pieces: connected components of this rank's unknowns (owned and halo: every coupling between two of them is one of
// the global system's). A piece is anchored if a row of it is; an owned row sees all its neighbours, so a group is
// anchored iff some rank's piece holding its anchored row says so. Pieces are joined where a halo unknown lies in a
// piece of its owner's: rank 0 joins them all.
template <int D>
std::vector<int> closed_groups_of_rows(BasicHalo<D>& halo, const PpeSystem& sys, std::size_t rows, int& closed_groups) {
  const MPI_Comm comm = to_comm(halo.comm());
  const int me = rank_of(comm), ranks = size_of(comm);
  const std::size_t m = sys.size(), n = halo.owned() + halo.copies();
  std::vector<int> parent(m);
  std::iota(parent.begin(), parent.end(), 0);
  for (std::size_t r = 0; r < m; ++r)
    for (int k = sys.matrix.row_ptr[r]; k < sys.matrix.row_ptr[r + 1]; ++k)
      join(parent, static_cast<int>(r), sys.matrix.col[static_cast<std::size_t>(k)]);
  std::vector<int> piece_of(m, -1), root_piece(m, -1);
  std::vector<char> piece_anchored;
  for (std::size_t r = 0; r < m; ++r) {
    int& p = root_piece[static_cast<std::size_t>(find_root(parent, static_cast<int>(r)))];
    if (p < 0) {
      p = static_cast<int>(piece_anchored.size());
      piece_anchored.push_back(0);
    }
    piece_of[r] = p;
    if (r < rows && sys.anchored[r]) piece_anchored[static_cast<std::size_t>(p)] = 1;
  }
  const int pieces = static_cast<int>(piece_anchored.size());
  int piece_base = 0;
  MPI_Exscan(&pieces, &piece_base, 1, MPI_INT, MPI_SUM, comm);
  if (me == 0) piece_base = 0;
  std::vector<int> label(n, -1);  // per particle: the global label of its owner's piece
  for (std::size_t r = 0; r < rows; ++r) label[static_cast<std::size_t>(sys.particle[r])] = piece_base + piece_of[r];
  halo.refresh(label);
  std::vector<int> pairs;  // (this rank's piece, owner's piece), each pair once
  for (std::size_t r = rows; r < m; ++r) {
    const int there = label[static_cast<std::size_t>(sys.particle[r])];
    if (there < 0) throw std::logic_error("assemble_distributed_ppe: a halo unknown is no unknown to its owner");
    pairs.push_back(piece_base + piece_of[r]);
    pairs.push_back(there);
  }
  {
    std::vector<std::pair<int, int>> unique;
    for (std::size_t k = 0; k < pairs.size(); k += 2) unique.emplace_back(pairs[k], pairs[k + 1]);
    std::sort(unique.begin(), unique.end());
    unique.erase(std::unique(unique.begin(), unique.end()), unique.end());
    pairs.clear();
    for (const auto& [a1, b1] : unique) {
      pairs.push_back(a1);
      pairs.push_back(b1);
    }
  }
  // Gathered on rank 0: every rank's anchored flags (one per piece) and pairs.
  std::vector<int> counts(static_cast<std::size_t>(ranks)), pair_counts(static_cast<std::size_t>(ranks));
  const int pair_count = static_cast<int>(pairs.size());
  MPI_Gather(&pieces, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, comm);
  MPI_Gather(&pair_count, 1, MPI_INT, pair_counts.data(), 1, MPI_INT, 0, comm);
  std::vector<int> offsets(static_cast<std::size_t>(ranks) + 1, 0), pair_offsets(offsets.size(), 0);
  for (std::size_t q = 0; q < counts.size(); ++q) {
    offsets[q + 1] = offsets[q] + counts[q];
    pair_offsets[q + 1] = pair_offsets[q] + pair_counts[q];
  }
  std::vector<int> anchored_in(piece_anchored.begin(), piece_anchored.end());
  std::vector<int> all_anchored(static_cast<std::size_t>(offsets.back())), all_pairs(static_cast<std::size_t>(pair_offsets.back()));
  MPI_Gatherv(anchored_in.data(), pieces, MPI_INT, all_anchored.data(), counts.data(), offsets.data(), MPI_INT, 0, comm);
  MPI_Gatherv(pairs.data(), pair_count, MPI_INT, all_pairs.data(), pair_counts.data(), pair_offsets.data(), MPI_INT, 0,
              comm);
  // Rank 0: each piece's closed group (numbered in order of its lowest label), or -1; sent back to the pieces' ranks.
  std::vector<int> all_groups(all_anchored.size(), -1);
  closed_groups = 0;
  if (me == 0) {
    std::vector<int> root(all_anchored.size());
    std::iota(root.begin(), root.end(), 0);
    for (std::size_t k = 0; k < all_pairs.size(); k += 2) join(root, all_pairs[k], all_pairs[k + 1]);
    std::vector<char> root_anchored(root.size(), 0);
    for (std::size_t p = 0; p < root.size(); ++p)
      if (all_anchored[p]) root_anchored[static_cast<std::size_t>(find_root(root, static_cast<int>(p)))] = 1;
    std::vector<int> group_of_root(root.size(), -1);
    for (std::size_t p = 0; p < root.size(); ++p) {
      const auto r = static_cast<std::size_t>(find_root(root, static_cast<int>(p)));
      if (root_anchored[r]) continue;
      if (group_of_root[r] < 0) group_of_root[r] = closed_groups++;
      all_groups[p] = group_of_root[r];
    }
  }
  MPI_Bcast(&closed_groups, 1, MPI_INT, 0, comm);
  std::vector<int> piece_group(static_cast<std::size_t>(pieces));
  MPI_Scatterv(all_groups.data(), counts.data(), offsets.data(), MPI_INT, piece_group.data(), pieces, MPI_INT, 0, comm);

  std::vector<int> group(rows);
  for (std::size_t r = 0; r < rows; ++r) group[r] = piece_group[static_cast<std::size_t>(piece_of[r])];
  return group;
}

// The gauge of ppe.hpp over each closed group as a whole: its rhs mean out, the lowest global member pinned.
void gauge_closed_groups(DistributedPpe& d, int closed_groups, MPI_Comm comm) {
  CsrMatrix& a = d.matrix;
  const std::size_t rows = d.rows();
  const long long first = d.first_row;
  std::vector<double> sum(static_cast<std::size_t>(closed_groups), 0.0);
  std::vector<long long> size(sum.size(), 0);
  std::vector<int> lowest(sum.size(), std::numeric_limits<int>::max());
  for (std::size_t r = 0; r < rows; ++r) {
    const int g = d.group[r];
    if (g < 0) continue;
    const auto gg = static_cast<std::size_t>(g);
    sum[gg] += d.rhs[r];
    ++size[gg];
    lowest[gg] = std::min(lowest[gg], static_cast<int>(first) + static_cast<int>(r));
  }
  MPI_Allreduce(MPI_IN_PLACE, sum.data(), closed_groups, MPI_DOUBLE, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, size.data(), closed_groups, MPI_LONG_LONG, MPI_SUM, comm);
  MPI_Allreduce(MPI_IN_PLACE, lowest.data(), closed_groups, MPI_INT, MPI_MIN, comm);
  d.closed.resize(sum.size());
  for (std::size_t g = 0; g < sum.size(); ++g)
    d.closed[g] = {lowest[g], static_cast<int>(size[g]), sum[g] / static_cast<double>(size[g])};
  for (std::size_t r = 0; r < rows; ++r) {
    const int g = d.group[r];
    if (g < 0) continue;
    const FloatingGroup& fg = d.closed[static_cast<std::size_t>(g)];
    d.rhs[r] -= fg.removed_rhs_mean;
    if (static_cast<long long>(fg.pinned) != first + static_cast<long long>(r)) continue;
    for (int k = a.row_ptr[r]; k < a.row_ptr[r + 1]; ++k)
      if (a.col[static_cast<std::size_t>(k)] == fg.pinned) a.val[static_cast<std::size_t>(k)] *= 2.0;
  }
}

}  // namespace

template <int D>
void assemble_distributed_ppe(BasicHalo<D>& halo, const BasicStencil<D>& s, std::span<const char> free_surface,
                              std::span<const double> source, std::span<const double> dirichlet, double shift,
                              DistributedPpe& d, OpenSupport open, PpeRows rows_wanted) {
  const std::size_t n = s.particles.size();
  if (n != halo.owned() + halo.copies() || free_surface.size() != n || source.size() != n ||
      (!dirichlet.empty() && dirichlet.size() != n) || (!open.weight.empty() && (open.weight.size() != n || open.value.size() != n)))
    throw std::invalid_argument("assemble_distributed_ppe: particles, free-surface flags, source and Dirichlet values "
                                "must have one entry per particle, owned and halo (" +
                                std::to_string(halo.owned()) + " + " + std::to_string(halo.copies()) + ")");
  if (s.kernel.re > halo.radius() || s.neighbors.radius > halo.radius())
    throw std::invalid_argument("assemble_distributed_ppe: the halo's radius " + std::to_string(halo.radius()) +
                                " is below the Laplacian's " + std::to_string(std::max(s.kernel.re, s.neighbors.radius)) +
                                ": owned rows next to another rank would miss neighbours; build the Halo with at least it");
  // The halo's flags and held values as their owners have them: a copy's row is not kept, but whether it is an
  // unknown or held, and at what, enters the owned rows next to it.
  std::vector<char> surface(free_surface.begin(), free_surface.end());
  halo.refresh(surface);
  std::vector<double> held(dirichlet.begin(), dirichlet.end());
  if (!held.empty()) halo.refresh(held);
  std::vector<double> open_weight(open.weight.begin(), open.weight.end()), open_value(open.value.begin(), open.value.end());
  if (!open_weight.empty()) {
    halo.refresh(open_weight);
    halo.refresh(open_value);
  }
  assemble_ppe<D>(s, surface, source, d.local, held, shift, ClosedGroups::leave, {open_weight, open_value},
                  rows_wanted);
  const PpeSystem& sys = d.local;
  const std::size_t m = sys.size();
  std::size_t rows = 0;  // owned particles come first, so their unknowns are the first rows
  while (rows < m && static_cast<std::size_t>(sys.particle[rows]) < halo.owned()) ++rows;

  number_globally(halo, rows, d);
  const auto owned_rows = sys.held.begin() + static_cast<std::ptrdiff_t>(rows);
  auto solved = static_cast<long long>(std::count(sys.held.begin(), owned_rows, 0));
  MPI_Allreduce(MPI_IN_PLACE, &solved, 1, MPI_LONG_LONG, MPI_SUM, to_comm(halo.comm()));
  d.solved_rows = solved;
  int closed_groups = 0;
  d.group = closed_groups_of_rows(halo, sys, rows, closed_groups);
  gauge_closed_groups(d, closed_groups, to_comm(halo.comm()));
}

template <int D>
SolveReport solve_distributed_ppe(BasicHalo<D>& halo, const DistributedPpe& ppe, LinearSolver& solver,
                                  BasicParticles<D>& particles,
                                  bool clamp_negative, std::span<const double> offset) {
  const std::size_t n = particles.size();
  if (n != halo.owned() + halo.copies() || (!offset.empty() && offset.size() != n))
    throw std::invalid_argument("solve_distributed_ppe: particles and offset must have one entry per particle, owned "
                                "and halo");
  const MPI_Comm comm = to_comm(halo.comm());
  const PpeSystem& sys = ppe.local;
  const std::size_t rows = ppe.rows();
  auto base = [&](std::size_t i) { return offset.empty() ? 0.0 : offset[i]; };
  // A held row (PpeRows::every_particle) starts at its value, which it keeps.
  std::vector<double> x(rows);
  for (std::size_t r = 0; r < rows; ++r) {
    const auto i = static_cast<std::size_t>(sys.particle[r]);
    x[r] = sys.held[r] ? ppe.rhs[r] / ppe.matrix.val[static_cast<std::size_t>(ppe.matrix.row_ptr[r])]
                       : particles.p[i] - base(i);
  }
  SolveReport report = solver.solve(ppe.matrix, ppe.rhs, x);

  std::vector<double> mean(ppe.closed.size(), 0.0);
  for (std::size_t r = 0; r < rows; ++r)
    if (ppe.group[r] >= 0) mean[static_cast<std::size_t>(ppe.group[r])] += x[r];
  MPI_Allreduce(MPI_IN_PLACE, mean.data(), static_cast<int>(mean.size()), MPI_DOUBLE, MPI_SUM, comm);
  for (std::size_t g = 0; g < mean.size(); ++g) mean[g] /= ppe.closed[g].size;
  for (std::size_t i = 0; i < halo.owned(); ++i)
    if (particles.kind[i] == Kind::fluid || particles.kind[i] == Kind::wall) particles.p[i] = 0.0;
  for (std::size_t r = 0; r < rows; ++r) {
    if (sys.held[r]) continue;  // stays 0 as a particle left out would, as PpeSystem::scatter leaves it
    const auto i = static_cast<std::size_t>(sys.particle[r]);
    const int g = ppe.group[r];
    if (g >= 0) particles.p[i] = x[r] - mean[static_cast<std::size_t>(g)] + base(i);
    else particles.p[i] = clamp_negative ? std::max(0.0, x[r] + base(i)) : x[r] + base(i);
  }
  halo.refresh(std::span<double>(particles.p));
  return report;
}

#define MPS_DISTRIBUTED_FOR(D)                                                                                       \
  template std::vector<int> partition_particles(const BasicParticles<D>&, int);                                      \
  template std::vector<int> RcbPartition::repartition(const BasicParticles<D>&);                                     \
  template std::vector<int> RcbPartition::assign(const BasicParticles<D>&) const;                                    \
  template int RcbPartition::assign<D>(const Vec<D>&) const;                                                         \
  template RcbPartition::Placement RcbPartition::place(const BasicParticles<D>&, double);                            \
  template ExchangeStats migrate_particles(BasicParticles<D>&, std::span<const int>, int);                            \
  template ExchangeStats distribute_particles(BasicParticles<D>&, int);                                               \
  template class BasicHalo<D>;                                                                                        \
  template DistributedPpe assemble_distributed_ppe(BasicHalo<D>&, const BasicStencil<D>&, std::span<const char>,     \
                                                   std::span<const double>, std::span<const double>, double);         \
  template void assemble_distributed_ppe(BasicHalo<D>&, const BasicStencil<D>&, std::span<const char>,               \
                                         std::span<const double>, std::span<const double>, double, DistributedPpe&,   \
                                         OpenSupport, PpeRows);                                                       \
  template SolveReport solve_distributed_ppe(BasicHalo<D>&, const DistributedPpe&, LinearSolver&, BasicParticles<D>&, \
                                             bool, std::span<const double>);
MPS_DISTRIBUTED_FOR(2)
MPS_DISTRIBUTED_FOR(3)
#undef MPS_DISTRIBUTED_FOR

}  // namespace mps
