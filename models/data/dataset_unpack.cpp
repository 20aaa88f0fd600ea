// dataset_unpack.cpp — .tar.zst extraction (libzstd streaming + a small ustar/GNU tar reader) and the one-time
// unpack of the Bandai archives into the cache (declared in models/data/dataset.h).
#include <unistd.h>
#include <zstd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>

#include "models/data/dataset.h"
#include "tensor/tensor.h"

namespace fs = std::filesystem;

namespace t2m::data {

namespace {

// Sequential reader of the decompressed bytes of a .zst file.
class ZstdReader {
 public:
  explicit ZstdReader(const std::string& path) : path_(path) {
    f_ = std::fopen(path.c_str(), "rb");
    if (!f_) throw Error("extract_tar_zst: cannot open '" + path + "'");
    ds_ = ZSTD_createDStream();
    if (!ds_) throw Error("extract_tar_zst: ZSTD_createDStream failed");
    ZSTD_DCtx_setParameter(ds_, ZSTD_d_windowLogMax, 31);
    in_buf_.resize(ZSTD_DStreamInSize());
    out_buf_.resize(ZSTD_DStreamOutSize());
  }
  ~ZstdReader() {
    if (ds_) ZSTD_freeDStream(ds_);
    if (f_) std::fclose(f_);
  }
  ZstdReader(const ZstdReader&) = delete;
  ZstdReader& operator=(const ZstdReader&) = delete;

  // Reads exactly n bytes into dst (dst may be null to skip). Returns false at a clean end of the stream before
  // the first byte; throws if the stream ends in the middle.
  bool read(char* dst, size_t n) {
    size_t got = 0;
    while (got < n) {
      if (out_pos_ == out_len_ && !refill()) {
        if (got == 0) return false;
        throw Error("extract_tar_zst: '" + path_ + "' ends in the middle of a tar record (truncated archive)");
      }
      const size_t k = std::min(n - got, out_len_ - out_pos_);
      if (dst) std::memcpy(dst + got, out_buf_.data() + out_pos_, k);
      out_pos_ += k, got += k;
    }
    return true;
  }

 private:
  bool refill() {
    out_pos_ = out_len_ = 0;
    for (;;) {
      if (in_.pos == in_.size) {
        const size_t r = std::fread(in_buf_.data(), 1, in_buf_.size(), f_);
        if (r == 0) {
          if (std::ferror(f_)) throw Error("extract_tar_zst: read error on '" + path_ + "'");
          if (last_ret_ != 0) throw Error("extract_tar_zst: '" + path_ + "' is a truncated zstd stream");
          return false;
        }
        in_ = {in_buf_.data(), r, 0};
      }
      ZSTD_outBuffer out = {out_buf_.data(), out_buf_.size(), 0};
      last_ret_ = ZSTD_decompressStream(ds_, &out, &in_);
      if (ZSTD_isError(last_ret_))
        throw Error("extract_tar_zst: '" + path_ + "': zstd error: " + ZSTD_getErrorName(last_ret_));
      if (out.pos > 0) {
        out_len_ = out.pos;
        return true;
      }
    }
  }
  std::string path_;
  FILE* f_ = nullptr;
  ZSTD_DStream* ds_ = nullptr;
  std::vector<char> in_buf_, out_buf_;
  ZSTD_inBuffer in_ = {nullptr, 0, 0};
  size_t out_pos_ = 0, out_len_ = 0;
  size_t last_ret_ = 0;
};

// Octal (or GNU base-256) numeric header field.
uint64_t tar_number(const char* f, size_t n, const std::string& archive) {
  if ((unsigned char)f[0] & 0x80) {
    uint64_t v = (unsigned char)f[0] & 0x7f;
    for (size_t i = 1; i < n; ++i) {
      if (v >> 55) throw Error("extract_tar_zst: '" + archive + "': size field overflows");
      v = (v << 8) | (unsigned char)f[i];
    }
    return v;
  }
  uint64_t v = 0;
  size_t i = 0;
  while (i < n && (f[i] == ' ' || f[i] == '\0')) ++i;
  for (; i < n && f[i] >= '0' && f[i] <= '7'; ++i) {
    if (v >> 60) throw Error("extract_tar_zst: '" + archive + "': numeric field overflows");
    v = v * 8 + uint64_t(f[i] - '0');
  }
  for (; i < n; ++i)
    if (f[i] != ' ' && f[i] != '\0') throw Error("extract_tar_zst: '" + archive + "': bad octal header field");
  return v;
}

std::string field(const char* f, size_t n) { return std::string(f, strnlen(f, n)); }

// Rejects absolute paths and ".." components; returns the relative path.
fs::path safe_relative(const std::string& name, const std::string& archive) {
  fs::path p(name);
  if (name.empty() || p.is_absolute()) throw Error("extract_tar_zst: '" + archive + "': unsafe entry '" + name + "'");
  for (const auto& part : p)
    if (part == "..") throw Error("extract_tar_zst: '" + archive + "': unsafe entry '" + name + "'");
  return p;
}

// Reads `size` bytes of entry data (plus padding to 512) into a string (for long names / pax headers).
std::string read_small(ZstdReader& r, uint64_t size, const std::string& archive) {
  if (size > (1u << 20)) throw Error("extract_tar_zst: '" + archive + "': oversized extended header");
  std::string s(size, '\0');
  if (size && !r.read(s.data(), size)) throw Error("extract_tar_zst: '" + archive + "': truncated");
  const uint64_t pad = (512 - size % 512) % 512;
  if (pad && !r.read(nullptr, pad)) throw Error("extract_tar_zst: '" + archive + "': truncated");
  return s;
}

// "path" from pax records "LEN key=value\n".
std::string pax_path(const std::string& s) {
  size_t p = 0;
  std::string path;
  while (p < s.size()) {
    const size_t sp = s.find(' ', p);
    if (sp == std::string::npos) break;
    const size_t len = std::strtoul(s.substr(p, sp - p).c_str(), nullptr, 10);
    if (len == 0 || p + len > s.size()) break;
    const std::string rec = s.substr(sp + 1, p + len - sp - 2);  // without the trailing '\n'
    if (rec.rfind("path=", 0) == 0) path = rec.substr(5);
    p += len;
  }
  return path;
}

void write_file_atomic(const fs::path& dest, const std::string& text) {
  const std::string tmp = dest.string() + ".tmp." + std::to_string(::getpid());
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw Error("dataset: cannot create '" + tmp + "'");
  const bool ok = std::fwrite(text.data(), 1, text.size(), f) == text.size();
  if (std::fclose(f) != 0 || !ok || std::rename(tmp.c_str(), dest.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw Error("dataset: cannot write '" + dest.string() + "'");
  }
}

}  // namespace

int extract_tar_zst(const std::string& archive, const std::string& dest_dir) {
  ZstdReader r(archive);
  std::error_code ec;
  fs::create_directories(dest_dir, ec);
  if (ec) throw Error("extract_tar_zst: cannot create '" + dest_dir + "': " + ec.message());
  int files = 0;
  std::string long_name;  // from a GNU 'L' or pax 'x' entry, applies to the next entry
  std::vector<char> buf(1 << 16);
  char h[512];
  for (;;) {
    if (!r.read(h, 512)) break;  // end of stream without the zero blocks: accepted
    bool zero = true;
    for (char c : h) zero = zero && c == 0;
    if (zero) break;
    uint64_t sum = 0;
    for (int i = 0; i < 512; ++i) sum += (i >= 148 && i < 156) ? ' ' : (unsigned char)h[i];
    if (sum != tar_number(h + 148, 8, archive))
      throw Error("extract_tar_zst: '" + archive + "': bad tar header checksum (not a tar archive or corrupt)");
    const uint64_t size = tar_number(h + 124, 12, archive);
    const char type = h[156];
    std::string name = field(h, 100);
    if (std::memcmp(h + 257, "ustar\0", 6) == 0 && h[345]) name = field(h + 345, 155) + "/" + name;
    if (type == 'L' || type == 'x') {
      std::string s = read_small(r, size, archive);
      long_name = type == 'L' ? field(s.data(), s.size()) : pax_path(s);
      continue;
    }
    if (!long_name.empty()) name = long_name, long_name.clear();
    const uint64_t pad = (512 - size % 512) % 512;
    if (type == '5') {
      fs::create_directories(fs::path(dest_dir) / safe_relative(name, archive), ec);
      if (ec) throw Error("extract_tar_zst: cannot create directory for '" + name + "': " + ec.message());
    } else if (type == '0' || type == '\0' || type == '7') {
      const fs::path dest = fs::path(dest_dir) / safe_relative(name, archive);
      fs::create_directories(dest.parent_path(), ec);
      const std::string tmp = dest.string() + ".tmp." + std::to_string(::getpid());
      std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(tmp.c_str(), "wb"), &std::fclose);
      if (!f) throw Error("extract_tar_zst: cannot create '" + tmp + "'");
      for (uint64_t left = size; left > 0;) {
        const size_t k = (size_t)std::min<uint64_t>(left, buf.size());
        if (!r.read(buf.data(), k)) throw Error("extract_tar_zst: '" + archive + "': truncated in '" + name + "'");
        if (std::fwrite(buf.data(), 1, k, f.get()) != k) throw Error("extract_tar_zst: write failed: '" + tmp + "'");
        left -= k;
      }
      if (std::fclose(f.release()) != 0 || std::rename(tmp.c_str(), dest.c_str()) != 0) {
        std::remove(tmp.c_str());
        throw Error("extract_tar_zst: cannot write '" + dest.string() + "'");
      }
      ++files;
    } else {  // links, devices, global pax headers: skipped
      if (size && !r.read(nullptr, size)) throw Error("extract_tar_zst: '" + archive + "': truncated");
    }
    if (pad && !r.read(nullptr, pad))
      throw Error("extract_tar_zst: '" + archive + "': truncated");
  }
  return files;
}

std::string unpack_dataset(const std::string& data_dir, const std::string& cache_dir) {
  const fs::path root = fs::path(cache_dir) / "bandai";
  int found = 0;
  for (int n = 1; n <= 2; ++n) {
    const fs::path archive = fs::path(data_dir) / ("dataset-" + std::to_string(n) + ".tar.zst");
    std::error_code ec;
    if (!fs::exists(archive, ec)) continue;
    ++found;
    const std::string stamp = std::to_string(fs::file_size(archive, ec)) + "\n";
    const fs::path marker = root / (".unpacked-dataset-" + std::to_string(n));
    if (fs::exists(marker, ec)) {
      std::unique_ptr<FILE, int (*)(FILE*)> f(std::fopen(marker.c_str(), "rb"), &std::fclose);
      char b[64] = {0};
      if (f && std::fread(b, 1, sizeof b - 1, f.get()) > 0 && stamp == b) continue;  // already unpacked
    }
    std::fprintf(stderr, "t2m data: unpacking %s into %s\n", archive.c_str(), root.c_str());
    extract_tar_zst(archive.string(), root.string());
    write_file_atomic(marker, stamp);
  }
  if (found == 0)
    throw Error("unpack_dataset: no dataset-1.tar.zst or dataset-2.tar.zst in '" + data_dir +
                "' (set --data or T2M_DATA)");
  return root.string();
}

}  // namespace t2m::data
