#include "png.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <png.h>

#include "mps/io/io.hpp"

namespace acoustic {
namespace {

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
  std::vector<png_byte> palette(3 * 256);
  for (int i = 0; i < 256; ++i) {
    const auto c = colour(2.0 * i / 255.0 - 1.0);
    std::copy(c.begin(), c.end(), palette.begin() + 3 * i);
  }
  std::vector<png_byte> index(values.size());
  for (std::size_t k = 0; k < values.size(); ++k) {
    const double s = std::isfinite(values[k]) ? std::clamp(values[k] / range, -1.0, 1.0) : 0.0;
    index[k] = static_cast<png_byte>(std::lround((s + 1.0) * 127.5));
  }
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGB_COLORMAP;
  image.colormap_entries = 256;
  // A negative row stride: our row 0 is the bottom, PNG's first row the top.
  const png_int_32 stride = -static_cast<png_int_32>(width);
  png_alloc_size_t size = 0;
  if (png_image_write_to_memory(&image, nullptr, &size, 0, index.data(), stride, palette.data())) {
    std::string png(size, '\0');
    if (png_image_write_to_memory(&image, png.data(), &size, 0, index.data(), stride, palette.data())) {
      png.resize(size);
      mps::write_text(path, png);  // written aside and renamed into place: a stopped run never leaves half an image
      return;
    }
  }
  const std::string reason = image.message;
  png_image_free(&image);
  throw std::runtime_error("cannot encode " + path.string() + " as PNG: " + reason);
}

}  // namespace acoustic
