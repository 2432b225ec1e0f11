#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <limits>
#include <vector>

#include <png.h>

#include "png.hpp"

namespace {

namespace fs = std::filesystem;

using Rgb = std::array<int, 3>;

// The image decoded by libpng to 8-bit RGB, rows top to bottom.
std::vector<std::vector<Rgb>> decode(const fs::path& path, int& width, int& height) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) throw std::runtime_error(image.message);
  image.format = PNG_FORMAT_RGB;
  std::vector<png_byte> pixels(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) throw std::runtime_error(image.message);
  width = static_cast<int>(image.width);
  height = static_cast<int>(image.height);
  std::vector<std::vector<Rgb>> rows(image.height, std::vector<Rgb>(image.width));
  for (std::size_t r = 0; r < image.height; ++r)
    for (std::size_t c = 0; c < image.width; ++c)
      for (std::size_t q = 0; q < 3; ++q) rows[r][c][q] = pixels[3 * (r * image.width + c) + q];
  return rows;
}

// The map's colours where they are known by hand: -range is the first anchor (5, 48, 97), +range the last
// (103, 0, 31), values beyond are clipped to them, 0 and NaN are palette entry 128 (the white anchor a 1/255 step
// towards red: 247, 246, 246); row 0 of the values is the image's bottom row.
TEST(AcousticPng, PixelsDecodeToTheMapsColoursWithRowZeroAtTheBottom) {
  const double range = 2.0, nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> values{-2.0, 0.0, 2.0,     // row 0: the bottom
                                   9.0,  nan, -9.0};   // row 1: the top
  const fs::path file = fs::temp_directory_path() / "sparsemps_test_png" / "map.png";
  fs::create_directories(file.parent_path());
  acoustic::write_field_png(file, 3, 2, values, range);
  EXPECT_FALSE(fs::exists(file.string() + ".tmp"));
  int width = 0, height = 0;
  const auto rows = decode(file, width, height);
  ASSERT_EQ(width, 3);
  ASSERT_EQ(height, 2);
  const Rgb blue{5, 48, 97}, white{247, 246, 246}, red{103, 0, 31};
  EXPECT_EQ(rows[0], (std::vector<Rgb>{red, white, blue}));    // top: clipped +9, NaN, clipped -9
  EXPECT_EQ(rows[1], (std::vector<Rgb>{blue, white, red}));    // bottom: -range, 0, +range
  EXPECT_THROW(acoustic::write_field_png(file, 2, 2, values, range), std::invalid_argument);
}

}  // namespace
