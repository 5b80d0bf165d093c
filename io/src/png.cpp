// PNG encoder and base64 (see png.h).
#include "tet2spline/io/png.h"

#include <zlib.h>

#include <cstdlib>
#include <stdexcept>

#include "tet2spline/io/atomic_file.h"

namespace tet2spline {

namespace {

void putU32(std::vector<uint8_t>& out, uint32_t v) {
  out.push_back(uint8_t(v >> 24));
  out.push_back(uint8_t(v >> 16));
  out.push_back(uint8_t(v >> 8));
  out.push_back(uint8_t(v));
}

/// Length, type, data, CRC-32 over type and data (PNG spec, section 5.3).
void putChunk(std::vector<uint8_t>& out, const char type[4], const std::vector<uint8_t>& data) {
  putU32(out, uint32_t(data.size()));
  const size_t typeAt = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  const uLong crc = crc32(0L, out.data() + typeAt, uInt(out.size() - typeAt));
  putU32(out, uint32_t(crc));
}

uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return uint8_t(a);
  if (pb <= pc) return uint8_t(b);
  return uint8_t(c);
}

/// Filter type byte followed by the filtered row, for each row; the filter per row
/// minimises the sum of |signed residual| (a cheap proxy for compressibility).
std::vector<uint8_t> filterRows(const Image& im) {
  const size_t bpp = size_t(im.channels);
  const size_t stride = size_t(im.width) * bpp;
  std::vector<uint8_t> out;
  out.reserve((stride + 1) * size_t(im.height));
  std::vector<uint8_t> zero(stride, 0), candidate(stride), best(stride);
  for (int y = 0; y < im.height; ++y) {
    const uint8_t* row = im.pixels.data() + size_t(y) * stride;
    const uint8_t* up = y > 0 ? row - stride : zero.data();
    unsigned long bestCost = ~0ul;
    uint8_t bestType = 0;
    for (uint8_t type = 0; type <= 4; ++type) {
      unsigned long cost = 0;
      for (size_t i = 0; i < stride; ++i) {
        const int a = i >= bpp ? row[i - bpp] : 0;
        const int b = up[i];
        const int c = i >= bpp ? up[i - bpp] : 0;
        int pred = 0;
        switch (type) {
          case 0: pred = 0; break;
          case 1: pred = a; break;
          case 2: pred = b; break;
          case 3: pred = (a + b) / 2; break;
          default: pred = paeth(a, b, c); break;
        }
        const uint8_t r = uint8_t(row[i] - pred);
        candidate[i] = r;
        cost += r < 128 ? r : 256 - r;
      }
      if (cost < bestCost) {
        bestCost = cost;
        bestType = type;
        best.swap(candidate);
      }
    }
    out.push_back(bestType);
    out.insert(out.end(), best.begin(), best.end());
  }
  return out;
}

}  // namespace

std::vector<uint8_t> encodePng(const Image& image, int compressionLevel) {
  if (image.empty()) throw std::invalid_argument("encodePng: empty image");
  if (image.channels != 3 && image.channels != 4)
    throw std::invalid_argument("encodePng: " + std::to_string(image.channels) +
                                " channels; only RGB (3) and RGBA (4) are supported");
  const size_t expected = size_t(image.width) * size_t(image.height) * size_t(image.channels);
  if (image.pixels.size() != expected)
    throw std::invalid_argument("encodePng: pixel buffer holds " + std::to_string(image.pixels.size()) +
                                " bytes, expected " + std::to_string(expected));
  if (compressionLevel < 0 || compressionLevel > 9)
    throw std::invalid_argument("encodePng: compression level " + std::to_string(compressionLevel) + " not in 0..9");

  const std::vector<uint8_t> raw = filterRows(image);
  uLongf packedSize = compressBound(uLong(raw.size()));
  std::vector<uint8_t> packed(packedSize);
  if (compress2(packed.data(), &packedSize, raw.data(), uLong(raw.size()), compressionLevel) != Z_OK)
    throw std::runtime_error("encodePng: zlib compress2 failed");
  packed.resize(packedSize);

  std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<uint8_t> ihdr;
  putU32(ihdr, uint32_t(image.width));
  putU32(ihdr, uint32_t(image.height));
  ihdr.push_back(8);                                // bit depth
  ihdr.push_back(image.channels == 4 ? 6 : 2);      // colour type: RGBA or RGB
  ihdr.push_back(0);                                // deflate
  ihdr.push_back(0);                                // adaptive filtering
  ihdr.push_back(0);                                // no interlace
  putChunk(png, "IHDR", ihdr);
  putChunk(png, "IDAT", packed);
  putChunk(png, "IEND", {});
  return png;
}

void writePng(const Image& image, const std::string& path) {
  const std::vector<uint8_t> bytes = encodePng(image);
  AtomicFile file(path, /*binary=*/true);
  file.stream().write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  file.commit();
}

std::string base64Encode(const uint8_t* data, size_t size) {
  static const char* const kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 3 <= size; i += 3) {
    const uint32_t v = uint32_t(data[i]) << 16 | uint32_t(data[i + 1]) << 8 | data[i + 2];
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == size) {
    const uint32_t v = uint32_t(data[i]) << 16;
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == size) {
    const uint32_t v = uint32_t(data[i]) << 16 | uint32_t(data[i + 1]) << 8;
    out += kAlphabet[v >> 18];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

std::string pngDataUri(const Image& image) { return "data:image/png;base64," + base64Encode(encodePng(image)); }

}  // namespace tet2spline
