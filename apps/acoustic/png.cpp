#include "png.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace acoustic {
namespace {

using Bytes = std::vector<std::uint8_t>;

std::uint32_t crc32(const std::uint8_t* data, std::size_t n, std::uint32_t crc = 0) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  crc = ~crc;
  for (std::size_t i = 0; i < n; ++i) crc = table[(crc ^ data[i]) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

void put32(Bytes& out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<std::uint8_t>(v >> shift));
}

void chunk(Bytes& out, const char* type, const Bytes& data) {
  put32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  put32(out, crc32(out.data() + start, out.size() - start));
}

// A zlib stream of stored deflate blocks (RFC 1950/1951): no compression, so no compressor needed.
Bytes zlib_stored(const Bytes& raw) {
  Bytes z{0x78, 0x01};
  std::size_t pos = 0;
  do {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - pos);
    z.push_back(pos + n == raw.size() ? 1 : 0);
    z.push_back(static_cast<std::uint8_t>(n & 0xFF));
    z.push_back(static_cast<std::uint8_t>(n >> 8));
    z.push_back(static_cast<std::uint8_t>(~n & 0xFF));
    z.push_back(static_cast<std::uint8_t>((~n >> 8) & 0xFF));
    z.insert(z.end(), raw.begin() + static_cast<std::ptrdiff_t>(pos), raw.begin() + static_cast<std::ptrdiff_t>(pos + n));
    pos += n;
  } while (pos < raw.size());
  std::uint32_t a = 1, b = 0;
  for (std::uint8_t byte : raw) {
    a = (a + byte) % 65521u;
    b = (b + a) % 65521u;
  }
  put32(z, (b << 16) | a);
  return z;
}

// Diverging map through five anchors (dark blue, blue, white, red, dark red) for -1 .. 1.
std::array<std::uint8_t, 3> colour(double s) {
  static const double anchors[5][3] = {{5, 48, 97}, {67, 147, 195}, {247, 247, 247}, {214, 96, 77}, {103, 0, 31}};
  const double f = std::clamp((s + 1.0) * 2.0, 0.0, 4.0);
  const int k = std::min(3, static_cast<int>(f));
  const double t = f - k;
  std::array<std::uint8_t, 3> c{};
  for (int q = 0; q < 3; ++q) c[static_cast<std::size_t>(q)] = static_cast<std::uint8_t>(std::lround((1 - t) * anchors[k][q] + t * anchors[k + 1][q]));
  return c;
}

}  // namespace

void write_field_png(const std::filesystem::path& path, int width, int height, std::span<const double> values,
                     double range) {
  if (width <= 0 || height <= 0 || values.size() != static_cast<std::size_t>(width) * static_cast<std::size_t>(height))
    throw std::invalid_argument("write_field_png: values do not match width x height");
  if (!(range > 0.0)) range = 1.0;
  Bytes header;
  put32(header, static_cast<std::uint32_t>(width));
  put32(header, static_cast<std::uint32_t>(height));
  header.insert(header.end(), {8, 3, 0, 0, 0});  // 8-bit palette indices, no interlace
  Bytes palette;
  for (int i = 0; i < 256; ++i) {
    const auto c = colour(2.0 * i / 255.0 - 1.0);
    palette.insert(palette.end(), c.begin(), c.end());
  }
  Bytes raw;
  raw.reserve(static_cast<std::size_t>(height) * (static_cast<std::size_t>(width) + 1));
  for (int row = height - 1; row >= 0; --row) {  // PNG rows run top to bottom
    raw.push_back(0);                             // filter: none
    for (int col = 0; col < width; ++col) {
      const double v = values[static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(col)];
      const double s = std::isfinite(v) ? std::clamp(v / range, -1.0, 1.0) : 0.0;
      raw.push_back(static_cast<std::uint8_t>(std::lround((s + 1.0) * 127.5)));
    }
  }
  Bytes png{0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  chunk(png, "IHDR", header);
  chunk(png, "PLTE", palette);
  chunk(png, "IDAT", zlib_stored(raw));
  chunk(png, "IEND", {});
  // Written aside and renamed into place, as mps/io does, so a stopped run never leaves half an image.
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw std::runtime_error("cannot write " + tmp.string());
    out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    if (!out) throw std::runtime_error("failed writing " + tmp.string());
  }
  std::filesystem::rename(tmp, path);
}

}  // namespace acoustic
