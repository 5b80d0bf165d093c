#pragma once
/// PNG encoding (8-bit RGB/RGBA, zlib-compressed IDAT, CRC-32 per chunk, per-row
/// adaptive filter chosen by the minimum-sum-of-absolute-differences heuristic of
/// the PNG specification, section 12.8) and base64 for data: URIs (RFC 4648).
/// Output is a pure function of the input: same image, same bytes.

#include <cstdint>
#include <string>
#include <vector>

#include "tet2spline/io/image.h"

namespace tet2spline {

/// The PNG file's bytes. Throws std::invalid_argument (naming encodePng) when the
/// image is empty, has 1, 2 or > 4 channels, or its pixel buffer has the wrong size.
std::vector<uint8_t> encodePng(const Image& image, int compressionLevel = 6);

/// Writes encodePng(image) to `path` through AtomicFile (no partial file on failure).
void writePng(const Image& image, const std::string& path);

/// Standard base64 alphabet with '=' padding, no line breaks.
std::string base64Encode(const uint8_t* data, size_t size);
inline std::string base64Encode(const std::vector<uint8_t>& bytes) { return base64Encode(bytes.data(), bytes.size()); }

/// "data:image/png;base64,..." for embedding in HTML.
std::string pngDataUri(const Image& image);

}  // namespace tet2spline
