// checkpoint.cpp — serialisation of Checkpoint (see checkpoint.h for the file layout).
#include "nn/checkpoint.h"

#include <fcntl.h>
#include <nmmintrin.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

namespace t2m::nn {
namespace {

constexpr char kMagic[8] = {'T', '2', 'M', 'C', 'K', 'P', 'T', '1'};
constexpr uint32_t kTrailerMagic = 0x454d3254;  // "T2ME" little-endian
constexpr size_t kAlign = 64;
constexpr size_t kPrefixBytes = 8 + 4 + 4 + 8;
constexpr size_t kTrailerBytes = 8 + 4 + 4;

size_t align_up(size_t n) { return (n + kAlign - 1) / kAlign * kAlign; }

template <typename T>
void put_le(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

template <typename T>
T get_le(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

DType dtype_from_name(const std::string& s, const std::string& where) {
  if (s == "f32") return DType::f32;
  if (s == "f64") return DType::f64;
  if (s == "i64") return DType::i64;
  throw Error(where + "unknown dtype '" + s + "'");
}

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw Error("checkpoint " + path + ": " + what);
}

}  // namespace

uint32_t crc32c(const void* data, size_t n, uint32_t crc) {
  const auto* p = static_cast<const unsigned char*>(data);
  uint64_t c = ~crc;
  while (n >= 8) {
    uint64_t w;
    std::memcpy(&w, p, 8);
    c = _mm_crc32_u64(c, w);
    p += 8;
    n -= 8;
  }
  uint32_t c32 = (uint32_t)c;
  while (n--) c32 = _mm_crc32_u8(c32, *p++);
  return ~c32;
}

void write_file_atomic(const std::string& path, const std::string& bytes) {
  std::string tmp = path + ".tmp." + std::to_string(::getpid());
  int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw Error("cannot write " + path + ": " + std::strerror(errno));
  size_t done = 0;
  while (done < bytes.size()) {
    ssize_t w = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (w < 0) {
      if (errno == EINTR) continue;
      int e = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      throw Error("cannot write " + path + ": " + std::strerror(e));
    }
    done += (size_t)w;
  }
  if (::fsync(fd) != 0 || ::close(fd) != 0) {
    int e = errno;
    ::unlink(tmp.c_str());
    throw Error("cannot write " + path + ": " + std::strerror(e));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    int e = errno;
    ::unlink(tmp.c_str());
    throw Error("cannot write " + path + ": rename failed: " + std::strerror(e));
  }
}

void Checkpoint::put(const std::string& name, const Tensor& t) {
  if (name.empty()) throw Error("checkpoint put: empty tensor name");
  if (!t.defined()) throw Error("checkpoint put: tensor '" + name + "' is undefined");
  tensors_[name] = t;
}

const Tensor& Checkpoint::get(const std::string& name) const {
  auto it = tensors_.find(name);
  if (it == tensors_.end()) fail(source_, "no tensor named '" + name + "'");
  return it->second;
}

const Tensor& Checkpoint::expect(const std::string& name, const Shape& shape, DType dtype) const {
  const Tensor& t = get(name);
  if (t.shape() != shape || t.dtype() != dtype)
    fail(source_, "tensor '" + name + "' is " + dtype_name(t.dtype()) + shape_str(t.shape()) + ", expected " +
                      dtype_name(dtype) + shape_str(shape));
  return t;
}

std::vector<std::string> Checkpoint::names() const {
  std::vector<std::string> out;
  for (const auto& kv : tensors_) out.push_back(kv.first);
  return out;
}

void Checkpoint::save(const std::string& path) const {
  // Table first (offsets), then the bytes.
  nlohmann::json table = nlohmann::json::array();
  size_t data_bytes = 0;
  std::vector<Tensor> contig;
  contig.reserve(tensors_.size());
  for (const auto& [name, t] : tensors_) {
    Tensor c = t.contiguous();
    size_t nb = (size_t)c.numel() * dtype_size(c.dtype());
    table.push_back({{"name", name}, {"dtype", dtype_name(c.dtype())}, {"shape", c.shape()},
                     {"offset", data_bytes}, {"nbytes", nb}});
    data_bytes += align_up(nb);
    contig.push_back(c);
  }
  std::string header = nlohmann::json{{"meta", meta}, {"tensors", table}}.dump();

  std::string out;
  size_t header_end = align_up(kPrefixBytes + header.size());
  out.reserve(header_end + data_bytes + kTrailerBytes);
  out.append(kMagic, 8);
  put_le<uint32_t>(out, kVersion);
  put_le<uint32_t>(out, 0);
  put_le<uint64_t>(out, header.size());
  out += header;
  out.resize(header_end, '\0');
  for (const Tensor& c : contig) {
    size_t nb = (size_t)c.numel() * dtype_size(c.dtype());
    size_t at = out.size();
    out.resize(at + align_up(nb), '\0');
    if (nb) std::memcpy(out.data() + at, static_cast<const char*>(c.storage()->data) + c.offset() * dtype_size(c.dtype()), nb);
  }
  put_le<uint64_t>(out, data_bytes);
  put_le<uint32_t>(out, crc32c(out.data(), out.size()));
  put_le<uint32_t>(out, kTrailerMagic);
  write_file_atomic(path, out);
}

Checkpoint Checkpoint::load(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, std::string("cannot open: ") + std::strerror(errno));
  std::string buf((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (buf.size() < kPrefixBytes + kTrailerBytes) fail(path, "truncated (" + std::to_string(buf.size()) + " bytes)");
  if (std::memcmp(buf.data(), kMagic, 8) != 0) fail(path, "not a t2m checkpoint (bad magic)");
  uint32_t version = get_le<uint32_t>(buf.data() + 8);
  if (version != kVersion)
    fail(path, "unsupported version " + std::to_string(version) + " (this build reads " +
                   std::to_string(kVersion) + ")");
  uint64_t header_bytes = get_le<uint64_t>(buf.data() + 16);
  if (header_bytes > buf.size()) fail(path, "truncated (header of " + std::to_string(header_bytes) + " bytes)");
  size_t header_end = align_up(kPrefixBytes + header_bytes);
  if (get_le<uint32_t>(buf.data() + buf.size() - 4) != kTrailerMagic) fail(path, "truncated (no trailer)");
  uint64_t data_bytes = get_le<uint64_t>(buf.data() + buf.size() - kTrailerBytes);
  if (header_end + data_bytes + kTrailerBytes != buf.size())
    fail(path, "truncated or padded: size " + std::to_string(buf.size()) + " bytes, layout says " +
                   std::to_string(header_end + data_bytes + kTrailerBytes));
  uint32_t crc_stored = get_le<uint32_t>(buf.data() + buf.size() - 8);
  if (crc32c(buf.data(), buf.size() - 8) != crc_stored) fail(path, "checksum mismatch (file is corrupted)");

  nlohmann::json header;
  try {
    header = nlohmann::json::parse(buf.begin() + kPrefixBytes, buf.begin() + kPrefixBytes + header_bytes);
  } catch (const std::exception& e) {
    fail(path, std::string("malformed header: ") + e.what());
  }
  Checkpoint ck;
  ck.source_ = path;
  try {
    ck.meta = header.at("meta");
    for (const auto& e : header.at("tensors")) {
      std::string name = e.at("name").get<std::string>();
      DType dt = dtype_from_name(e.at("dtype").get<std::string>(), "checkpoint " + path + ": ");
      Shape shape = e.at("shape").get<Shape>();
      uint64_t offset = e.at("offset").get<uint64_t>(), nbytes = e.at("nbytes").get<uint64_t>();
      for (int64_t d : shape)
        if (d < 0) fail(path, "tensor '" + name + "' has a negative dimension");
      if ((uint64_t)shape_numel(shape) * dtype_size(dt) != nbytes)
        fail(path, "tensor '" + name + "' byte count does not match its shape " + shape_str(shape));
      if (offset > data_bytes || nbytes > data_bytes - offset)
        fail(path, "tensor '" + name + "' reaches past the data section");
      if (ck.tensors_.count(name)) fail(path, "duplicate tensor name '" + name + "'");
      Tensor t = Tensor::empty(shape, dt);
      if (nbytes) std::memcpy(t.storage()->data, buf.data() + header_end + offset, nbytes);
      ck.tensors_[name] = t;
    }
  } catch (const nlohmann::json::exception& e) {
    fail(path, std::string("malformed header: ") + e.what());
  }
  return ck;
}

}  // namespace t2m::nn
