// Screenshots to disk: RGBA pixels to a PNG through libpng, written beside the target and
// renamed, so a failed write never leaves half a file. GL-free.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace cvt::render {

// rgba: width × height × 4 bytes, rows top first. With keep_alpha false the alpha channel is
// dropped (an opaque RGB PNG). Throws cvt::InputError naming the path on failure.
void write_png(const std::string& path, int width, int height,
               const std::vector<std::uint8_t>& rgba, bool keep_alpha);

}  // namespace cvt::render
