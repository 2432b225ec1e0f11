#include "mps/solvers/registry.hpp"

#include <mpi.h>

#include <charconv>
#include <sstream>

namespace mps {
const std::vector<SolverEntry>& solver_registry() {
  static const std::vector<SolverEntry> entries = {auto_entry(),      eigen_cg_entry(),  eigen_bicgstab_entry(),
                                                   cholmod_entry(),   hypre_amg_entry(), hypre_pcg_entry(),
                                                   petsc_entry()};
  return entries;
}

namespace {

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t");
  return std::string(s.substr(b, e - b + 1));
}

std::string join_names(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// A serial backend handed one rank's block of rows would solve that block alone: a wrong answer, not an error.
void refuse_more_than_one_rank(const std::string& name, int fortran_comm) {
  int initialised = 0, finalized = 0;
  MPI_Initialized(&initialised);
  MPI_Finalized(&finalized);
  if (!initialised || finalized)
    throw std::invalid_argument("solver '" + name + "': SolverContext::mpi_comm is set but MPI is not running; set it "
                                "with MPI_Comm_c2f(comm) between MPI_Init and MPI_Finalize");
  int ranks = 1;
  MPI_Comm_size(MPI_Comm_f2c(fortran_comm), &ranks);
  if (ranks > 1)
    throw std::invalid_argument("solver '" + name + "' solves on one rank only, but the communicator has " +
                                std::to_string(ranks) +
                                " ranks; use hypre-pcg, hypre-amg, petsc or auto on more than one rank");
}

}  // namespace

SolverSpec parse_solver_spec(std::string_view spec) {
  SolverSpec out;
  const auto colon = spec.find(':');
  out.name = trim(spec.substr(0, colon));
  if (out.name.empty()) throw std::invalid_argument("solver spec '" + std::string(spec) + "' names no solver");
  if (colon == std::string_view::npos) return out;
  // Every item after the colon must be key=value: "name:" and a trailing comma are refused, not read as no option.
  std::string_view rest = spec.substr(colon + 1);
  for (;;) {
    const auto comma = rest.find(',');
    const std::string_view item = rest.substr(0, comma);
    const auto eq = item.find('=');
    const std::string key = trim(item.substr(0, eq));
    if (eq == std::string_view::npos || key.empty() || trim(item.substr(eq + 1)).empty())
      throw std::invalid_argument("solver spec '" + std::string(spec) + "': expected key=value, got '" +
                                  std::string(item) + "'");
    if (!out.options.emplace(key, trim(item.substr(eq + 1))).second)
      throw std::invalid_argument("solver spec '" + std::string(spec) + "' sets '" + key + "' twice");
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  return out;
}

std::unique_ptr<LinearSolver> make_solver(std::string_view spec) { return make_solver(spec, SolverContext{}); }

std::unique_ptr<LinearSolver> make_solver(std::string_view spec, const SolverContext& context) {
  const SolverSpec parsed = parse_solver_spec(spec);
  for (const auto& entry : solver_registry()) {
    if (entry.name != parsed.name) continue;
    std::map<std::string, std::string> values;
    for (const auto& key : entry.keys) values[key.name] = key.default_value;
    for (const auto& [key, value] : parsed.options) {
      if (!values.contains(key) && !entry.passes_other_keys) {
        std::vector<std::string> valid;
        for (const auto& k : entry.keys) valid.push_back(k.name);
        throw std::invalid_argument("solver '" + entry.name + "' has no key '" + key +
                                    "'; valid keys: " + join_names(valid));
      }
      values[key] = value;
    }
    if (context.mpi_comm && !entry.distributed) refuse_more_than_one_rank(entry.name, *context.mpi_comm);
    return entry.make(SolverOptions(entry.name, std::move(values)), context);
  }
  throw std::invalid_argument("unknown solver '" + parsed.name + "'; valid solvers: " + join_names(solver_names()));
}

std::vector<std::string> solver_names() {
  std::vector<std::string> names;
  for (const auto& entry : solver_registry()) names.push_back(entry.name);
  return names;
}

std::string describe_solvers() {
  std::ostringstream out;
  for (const auto& entry : solver_registry()) {
    out << entry.name << "\n    " << entry.summary << "\n";
    for (const auto& key : entry.keys)
      out << "    " << key.name << "=" << key.default_value << "  " << key.help << "\n";
    if (entry.passes_other_keys)
      out << "    any other key=value  passed through to the library behind it (see its summary)\n";
  }
  return out.str();
}

const std::string& SolverOptions::raw(const std::string& key) const {
  const auto it = values_.find(key);
  if (it == values_.end()) throw std::logic_error("solver '" + solver_ + "' reads undeclared key '" + key + "'");
  return it->second;
}

double SolverOptions::number(const std::string& key, double min, double max) const {
  const std::string& s = raw(key);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (ec != std::errc() || end != s.data() + s.size() || !(value >= min && value <= max)) {
    std::ostringstream msg;
    msg << "solver '" << solver_ << "': " << key << "=" << s << " is not a number in [" << min << ", " << max << "]";
    throw std::invalid_argument(msg.str());
  }
  return value;
}

int SolverOptions::integer(const std::string& key, int min, int max) const {
  const std::string& s = raw(key);
  int value = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), value);
  if (ec != std::errc() || end != s.data() + s.size() || value < min || value > max)
    throw std::invalid_argument("solver '" + solver_ + "': " + key + "=" + s + " is not an integer in [" +
                                std::to_string(min) + ", " + std::to_string(max) + "]");
  return value;
}

std::string SolverOptions::choice(const std::string& key, std::initializer_list<const char*> allowed) const {
  const std::string& s = raw(key);
  std::vector<std::string> names;
  for (const char* a : allowed) {
    if (s == a) return s;
    names.emplace_back(a);
  }
  throw std::invalid_argument("solver '" + solver_ + "': " + key + "=" + s + " is not one of " + join_names(names));
}

std::string SolverOptions::spec() const {
  std::string out = solver_;
  char sep = ':';
  for (const auto& [key, value] : values_) {
    out += sep + key + "=" + value;
    sep = ',';
  }
  return out;
}

}  // namespace mps
