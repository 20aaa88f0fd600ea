// checkpoint.h — the versioned binary checkpoint format: named tensors + JSON metadata + checksum.
//
// A Checkpoint is an ordered map name -> Tensor (parameters, optimizer moments, anything) plus a JSON object of
// metadata (step, RNG state, config, ...). save() writes atomically: a temporary file in the same directory,
// fsync, then rename, so a crash or a full disk never leaves a half-written checkpoint under the final name.
//
// File layout (little-endian), version 1:
//   magic "T2MCKPT1" (8 bytes) | u32 version | u32 reserved (0) | u64 header_bytes
//   header: UTF-8 JSON {"meta": {...}, "tensors": [{"name", "dtype", "shape", "offset", "nbytes"}, ...]}
//   padding to 64 bytes | tensor data (each entry 64-byte aligned, offsets relative to the data start)
//   trailer: u64 data_bytes | u32 crc32c of everything before the trailer | u32 magic2 "T2ME"
// Errors (t2m::Error, message starts with "checkpoint PATH: "): missing file, wrong magic, unsupported version,
// truncated file, checksum mismatch, malformed header, unknown dtype, duplicate names, a tensor reaching past the
// data, and (in get/expect) a missing name or a shape/dtype mismatch naming both shapes.
#pragma once
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tensor/tensor.h"

namespace t2m::nn {

class Checkpoint {
 public:
  static constexpr uint32_t kVersion = 1;

  nlohmann::json meta = nlohmann::json::object();

  // Adds (or replaces) a named tensor; the tensor is copied to contiguous memory on save, not now.
  void put(const std::string& name, const Tensor& t);
  bool has(const std::string& name) const { return tensors_.count(name) != 0; }
  // Returns the stored tensor; throws when the name is missing.
  const Tensor& get(const std::string& name) const;
  // Returns the stored tensor after checking it has exactly this shape and dtype (clear error otherwise).
  const Tensor& expect(const std::string& name, const Shape& shape, DType dtype) const;
  std::vector<std::string> names() const;  // sorted
  size_t size() const { return tensors_.size(); }

  void save(const std::string& path) const;
  static Checkpoint load(const std::string& path);

  const std::string& source() const { return source_; }  // the path it was loaded from (for error messages)

 private:
  std::map<std::string, Tensor> tensors_;
  std::string source_ = "<memory>";
};

// CRC-32C (Castagnoli) of a byte range, continuing from `crc` (0 for a fresh checksum).
uint32_t crc32c(const void* data, size_t n, uint32_t crc = 0);

// Writes `bytes` to `path` atomically (temp file in the same directory + fsync + rename). Throws t2m::Error
// naming the path on any failure and removes the temporary file.
void write_file_atomic(const std::string& path, const std::string& bytes);

}  // namespace t2m::nn
