#pragma once
// Pressure maps as PNG without an image library: an 8-bit palette image in zlib "stored" (uncompressed)
// blocks, so one byte per particle (a 400 x 400 map is 160 kB).
#include <filesystem>
#include <span>

namespace acoustic {

// values[j * width + i] is the pixel in column i of row j, row 0 at the bottom (y up). Colours: a diverging
// blue-white-red map over [-range, range]; values beyond it are clipped.
void write_field_png(const std::filesystem::path& path, int width, int height, std::span<const double> values,
                     double range);

}  // namespace acoustic
