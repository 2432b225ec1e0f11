#pragma once
/// \file
/// A run's state as data, for checkpoints (mps/io/io.hpp write_checkpoint, docs/restart.md): a JSON tree whose arrays
/// are byte strings of their values (CBOR typed arrays), so that they round-trip bitwise and cost their size in the file.
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include <nlohmann/json.hpp>

namespace mps {

/// Helpers of pack_array and unpack_array.
namespace state_detail {
/// The CBOR tag of an array of T: an RFC 8746 typed array (little-endian), so that any CBOR reader knows its element
/// type and an array is never read back as another type.
template <class T>
constexpr std::uint8_t subtype() {
  if constexpr (std::is_same_v<T, double>) return 86;  // float64
  else if constexpr (std::is_integral_v<T> && std::is_signed_v<T> && sizeof(T) == 4) return 78;  // sint32
  else if constexpr (std::is_integral_v<T> && std::is_signed_v<T> && sizeof(T) == 8) return 79;  // sint64
  else if constexpr (std::is_integral_v<T> && std::is_signed_v<T> && sizeof(T) == 1) return 72;  // sint8
  else if constexpr (sizeof(T) == 1) return 64;  // uint8: unsigned flags, Kind
  else static_assert(sizeof(T) == 0, "no checkpoint type for this element");
}
}  // namespace state_detail

/// The values of `values` as a byte string tagged with their type.
template <class T>
nlohmann::json pack_array(const std::vector<T>& values) {
  static_assert(std::is_trivially_copyable_v<T>);
  std::vector<std::uint8_t> bytes(values.size() * sizeof(T));
  if (!bytes.empty()) std::memcpy(bytes.data(), values.data(), bytes.size());
  return nlohmann::json::binary(std::move(bytes), state_detail::subtype<T>());
}

/// `state[key]` read back into `out` (replacing its contents); throws std::runtime_error naming the key when it is
/// missing, of another type or of a length that is no whole number of values.
template <class T>
void unpack_array(const nlohmann::json& state, std::string_view key, std::vector<T>& out) {
  const std::string name(key);
  const auto found = state.find(name);
  if (found == state.end() || !found->is_binary())
    throw std::runtime_error("checkpoint: no array '" + name + "' (a checkpoint of another scene or version?)");
  const auto& bin = found->get_binary();
  if (!bin.has_subtype() || bin.subtype() != state_detail::subtype<T>() || bin.size() % sizeof(T) != 0)
    throw std::runtime_error("checkpoint: array '" + name + "' holds another type of value");
  out.resize(bin.size() / sizeof(T));
  if (!out.empty()) std::memcpy(out.data(), bin.data(), bin.size());
}

/// unpack_array into `out`, refusing an array of another length than out's (a checkpoint of a scene of another size);
/// `out` is left as it was when refused.
template <class T>
void unpack_array_same_size(const nlohmann::json& state, std::string_view key, std::vector<T>& out) {
  std::vector<T> read;
  unpack_array(state, key, read);
  if (read.size() != out.size())
    throw std::runtime_error("checkpoint: array '" + std::string(key) + "' holds " + std::to_string(read.size()) +
                             " values, this run has " + std::to_string(out.size()) + " (a scene of another size?)");
  out = std::move(read);
}

/// `state[key]`, a part of the tree; throws std::runtime_error naming the key when it is missing.
inline const nlohmann::json& state_part(const nlohmann::json& state, std::string_view key) {
  const auto found = state.find(std::string(key));
  if (found == state.end())
    throw std::runtime_error("checkpoint: no part '" + std::string(key) + "' (a checkpoint of another scene or version?)");
  return *found;
}

/// `state[key]` as a T; throws std::runtime_error naming the key when it is missing or of another type.
template <class T>
T unpack_value(const nlohmann::json& state, std::string_view key) {
  const std::string name(key);
  const auto found = state.find(name);
  if (found == state.end())
    throw std::runtime_error("checkpoint: no value '" + name + "' (a checkpoint of another scene or version?)");
  try {
    return found->get<T>();
  } catch (const nlohmann::json::exception&) {
    throw std::runtime_error("checkpoint: value '" + name + "' is of another type");
  }
}

/// A count each process kept (fluid removed, ...) added up over `parts`, for merge_states: {key: the sum}.
inline nlohmann::json summed(const std::vector<const nlohmann::json*>& parts, std::string_view key) {
  long sum = 0;
  for (const auto* part : parts) sum += unpack_value<long>(*part, key);
  return {{std::string(key), sum}};
}

}  // namespace mps
