// PNG encoder checked by an independent decoder (zlib inflate + PNG unfiltering) and base64 vectors.
#include "tet2spline/io/png.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include "tet2spline/param/error.h"

using namespace tet2spline;

namespace {

uint32_t be32(const uint8_t* p) { return uint32_t(p[0]) << 24 | uint32_t(p[1]) << 16 | uint32_t(p[2]) << 8 | p[3]; }

struct Decoded {
  Image image;
  std::vector<std::string> chunkTypes;
  std::set<int> filters;
};

/// A strict decoder for what encodePng promises: 8-bit RGB/RGBA, no interlace.
Decoded decodePng(const std::vector<uint8_t>& png) {
  Decoded d;
  const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  EXPECT_GE(png.size(), 8u);
  EXPECT_TRUE(std::equal(sig, sig + 8, png.begin())) << "bad signature";
  size_t at = 8;
  std::vector<uint8_t> idat;
  int colorType = -1;
  while (at + 12 <= png.size()) {
    const uint32_t len = be32(&png[at]);
    EXPECT_LE(at + 12 + len, png.size()) << "chunk overruns the file";
    if (at + 12 + len > png.size()) break;
    const std::string type(reinterpret_cast<const char*>(&png[at + 4]), 4);
    const uint8_t* data = &png[at + 8];
    const uint32_t crc = be32(&png[at + 8 + len]);
    EXPECT_EQ(crc, uint32_t(crc32(0L, &png[at + 4], uInt(len + 4)))) << "CRC of " << type;
    d.chunkTypes.push_back(type);
    if (type == "IHDR") {
      EXPECT_EQ(len, 13u);
      d.image.width = int(be32(data));
      d.image.height = int(be32(data + 4));
      EXPECT_EQ(data[8], 8) << "bit depth";
      colorType = data[9];
      EXPECT_TRUE(colorType == 2 || colorType == 6) << colorType;
      EXPECT_EQ(data[10], 0);
      EXPECT_EQ(data[11], 0);
      EXPECT_EQ(data[12], 0) << "interlace";
      d.image.channels = colorType == 6 ? 4 : 3;
    } else if (type == "IDAT") {
      idat.insert(idat.end(), data, data + len);
    }
    at += 12 + len;
  }
  EXPECT_EQ(at, png.size()) << "trailing bytes";
  const size_t bpp = size_t(d.image.channels), stride = size_t(d.image.width) * bpp;
  std::vector<uint8_t> raw((stride + 1) * size_t(d.image.height));
  uLongf rawSize = uLongf(raw.size());
  EXPECT_EQ(uncompress(raw.data(), &rawSize, idat.data(), uLong(idat.size())), Z_OK);
  EXPECT_EQ(rawSize, raw.size());
  d.image.pixels.assign(stride * size_t(d.image.height), 0);
  for (size_t y = 0; y < size_t(d.image.height); ++y) {
    const int f = raw[y * (stride + 1)];
    d.filters.insert(f);
    EXPECT_LE(f, 4) << "filter byte of row " << y;
    const uint8_t* in = &raw[y * (stride + 1) + 1];
    uint8_t* out = &d.image.pixels[y * stride];
    const uint8_t* up = y ? out - stride : nullptr;
    for (size_t i = 0; i < stride; ++i) {
      const int a = i >= bpp ? out[i - bpp] : 0, b = up ? up[i] : 0, c = (up && i >= bpp) ? up[i - bpp] : 0;
      int pred = 0;
      if (f == 1) pred = a;
      if (f == 2) pred = b;
      if (f == 3) pred = (a + b) / 2;
      if (f == 4) {
        const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
        pred = (pa <= pb && pa <= pc) ? a : pb <= pc ? b : c;
      }
      out[i] = uint8_t(in[i] + pred);
    }
  }
  return d;
}

Image testImage(int w, int h, int channels, int pattern) {
  Image im(w, h, channels);
  uint32_t seed = 12345;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c) {
        seed = seed * 1664525u + 1013904223u;
        uint8_t v = 0;
        switch (pattern) {
          case 0: v = uint8_t(seed >> 24); break;               // noise
          case 1: v = uint8_t(x * 3 + c * 40); break;            // horizontal ramp
          case 2: v = uint8_t(y * 5 + c * 17); break;            // vertical ramp
          default: v = uint8_t((x * y + c * 31) ^ (x + y)); break;  // texture
        }
        im.at(x, y)[c] = v;
      }
  return im;
}

}  // namespace

TEST(Png, RoundTripThroughZlibAndUnfiltering) {
  std::set<int> filtersSeen;
  for (const int channels : {3, 4})
    for (const int pattern : {0, 1, 2, 3})
      for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {7, 3}, {64, 48}, {33, 65}}) {
        const Image im = testImage(w, h, channels, pattern);
        const Decoded d = decodePng(encodePng(im));
        EXPECT_EQ(d.image.width, w);
        EXPECT_EQ(d.image.height, h);
        EXPECT_EQ(d.image.channels, channels);
        EXPECT_EQ(d.image.pixels, im.pixels) << w << "x" << h << " channels " << channels << " pattern " << pattern;
        EXPECT_EQ(d.chunkTypes, (std::vector<std::string>{"IHDR", "IDAT", "IEND"}));
        filtersSeen.insert(d.filters.begin(), d.filters.end());
      }
  // The adaptive choice exercises more than one filter on these images.
  EXPECT_GE(filtersSeen.size(), 3u);
}

TEST(Png, EveryCompressionLevelDecodes) {
  const Image im = testImage(40, 30, 3, 3);
  for (int level = 0; level <= 9; ++level) EXPECT_EQ(decodePng(encodePng(im, level)).image.pixels, im.pixels) << level;
}

TEST(Png, SameImageSameBytes) {
  const Image im = testImage(50, 20, 4, 3);
  EXPECT_EQ(encodePng(im), encodePng(im));
}

TEST(Png, RefusesBadImages) {
  Image two(4, 4, 2);
  EXPECT_THROW(encodePng(two), std::invalid_argument);
  Image wrong(4, 4, 3);
  wrong.pixels.pop_back();
  EXPECT_THROW(encodePng(wrong), std::invalid_argument);
  EXPECT_THROW(encodePng(Image()), std::invalid_argument);
  try {
    encodePng(two);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("encodePng"), std::string::npos);
  }
}

TEST(Png, WritePngWritesTheEncodedBytesAtomically) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::current_path() / "io_test_tmp" / "png_write";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const Image im = testImage(20, 10, 3, 1);
  const std::string path = (dir / "a.png").string();
  writePng(im, path);
  std::ifstream in(path, std::ios::binary);
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(bytes, encodePng(im));
  const std::string bad = (dir / "missing" / "b.png").string();
  EXPECT_THROW(writePng(im, bad), Error);
  EXPECT_FALSE(fs::exists(bad));
  // A bad image throws before anything is created.
  EXPECT_THROW(writePng(Image(2, 2, 2), (dir / "c.png").string()), std::invalid_argument);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
}

TEST(Base64, Rfc4648Vectors) {
  auto enc = [](const std::string& s) { return base64Encode(reinterpret_cast<const uint8_t*>(s.data()), s.size()); };
  EXPECT_EQ(enc(""), "");
  EXPECT_EQ(enc("f"), "Zg==");
  EXPECT_EQ(enc("fo"), "Zm8=");
  EXPECT_EQ(enc("foo"), "Zm9v");
  EXPECT_EQ(enc("foob"), "Zm9vYg==");
  EXPECT_EQ(enc("fooba"), "Zm9vYmE=");
  EXPECT_EQ(enc("foobar"), "Zm9vYmFy");
  const std::vector<uint8_t> high = {0xff, 0xfe, 0xfd, 0x00, 0x3e, 0x3f};
  EXPECT_EQ(base64Encode(high), "//79AD4/");
}

TEST(Base64, DataUriHoldsThePng) {
  const Image im = testImage(3, 2, 3, 0);
  const std::string uri = pngDataUri(im);
  const std::string prefix = "data:image/png;base64,";
  ASSERT_EQ(uri.rfind(prefix, 0), 0u);
  EXPECT_EQ(uri.substr(prefix.size()), base64Encode(encodePng(im)));
  EXPECT_EQ(uri.substr(prefix.size(), 8), "iVBORw0K");  // base64 of the PNG signature
}
