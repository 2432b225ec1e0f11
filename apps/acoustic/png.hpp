#pragma once
// Pressure maps as PNG (libpng): an 8-bit palette image, one byte per particle before compression.
#include <filesystem>
#include <span>

namespace acoustic {

// values[j * width + i] is the pixel in column i of row j, row 0 at the bottom (y up). Colours: a diverging
// blue-white-red map over [-range, range]; values beyond it are clipped, NaN is drawn as 0. Written atomically; a
// failure throws with libpng's reason and the path.
void write_field_png(const std::filesystem::path& path, int width, int height, std::span<const double> values,
                     double range);

}  // namespace acoustic
