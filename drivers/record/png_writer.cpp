// Unfiltered PNG encoding with zlib.
#include "drivers/record/png_writer.h"

#include <zlib.h>

#include <algorithm>
#include <cstring>

namespace mocap {
namespace {

void putBigEndian32(std::vector<uint8_t>& out, uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(static_cast<uint8_t>(value >> shift));
}

// Appends one chunk: length, type, data, CRC of type and data.
void putChunk(std::vector<uint8_t>& out, const char (&type)[5], const uint8_t* data,
              std::size_t size) {
  putBigEndian32(out, static_cast<uint32_t>(size));
  const std::size_t type_at = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data, data + size);
  const uLong crc = crc32(0L, out.data() + type_at, static_cast<uInt>(size + 4));
  putBigEndian32(out, static_cast<uint32_t>(crc));
}

}  // namespace

bool encodePng(const cv::Mat& image, int level, std::vector<uint8_t>& out) {
  const int channels = image.type() == CV_8UC1 ? 1 : image.type() == CV_8UC3 ? 3 : 0;
  if (channels == 0 || image.empty()) return false;
  const std::size_t row_bytes = static_cast<std::size_t>(image.cols) * channels;

  z_stream zs{};
  if (deflateInit2(&zs, std::clamp(level, 0, 9), Z_DEFLATED, 15, 8, Z_RLE) != Z_OK) return false;
  std::vector<uint8_t> compressed(deflateBound(&zs, (row_bytes + 1) * image.rows));
  zs.next_out = compressed.data();
  zs.avail_out = static_cast<uInt>(compressed.size());
  std::vector<uint8_t> row(row_bytes + 1);
  row[0] = 0;  // filter type None
  bool ok = true;
  for (int y = 0; y < image.rows && ok; ++y) {
    const uint8_t* src = image.ptr<uint8_t>(y);
    if (channels == 3) {  // BGR -> RGB
      for (int x = 0; x < image.cols; ++x) {
        row[1 + 3 * x] = src[3 * x + 2];
        row[2 + 3 * x] = src[3 * x + 1];
        row[3 + 3 * x] = src[3 * x];
      }
    } else {
      std::memcpy(row.data() + 1, src, row_bytes);
    }
    zs.next_in = row.data();
    zs.avail_in = static_cast<uInt>(row.size());
    ok = deflate(&zs, y + 1 == image.rows ? Z_FINISH : Z_NO_FLUSH) != Z_STREAM_ERROR &&
         zs.avail_in == 0;
  }
  ok = ok && zs.avail_out > 0;
  const std::size_t compressed_size = compressed.size() - zs.avail_out;
  deflateEnd(&zs);
  if (!ok) return false;

  out.clear();
  out.reserve(compressed_size + 64);
  static const uint8_t kSignature[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  out.insert(out.end(), kSignature, kSignature + 8);
  std::vector<uint8_t> header;
  putBigEndian32(header, static_cast<uint32_t>(image.cols));
  putBigEndian32(header, static_cast<uint32_t>(image.rows));
  header.insert(header.end(), {8, static_cast<uint8_t>(channels == 3 ? 2 : 0), 0, 0, 0});
  putChunk(out, "IHDR", header.data(), header.size());
  putChunk(out, "IDAT", compressed.data(), compressed_size);
  putChunk(out, "IEND", nullptr, 0);
  return true;
}

}  // namespace mocap
