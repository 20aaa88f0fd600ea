// motion_dir.cpp — motions.json + .npy/.bvh loading for `t2m eval motions`.
#include "models/eval/motion_dir.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "models/data/features.h"
#include "nn/checkpoint.h"
#include "sim/bvh.h"
#include "sim/skeleton.h"
#include "tensor/tensor.h"

namespace t2m::eval {

namespace fs = std::filesystem;

namespace {

std::string read_all(const std::string& path, const char* what) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(std::string(what) + " " + path + ": cannot open");
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The value of 'key': ... in a NumPy header dict (up to the next top-level ',' or '}').
std::string npy_field(const std::string& h, const std::string& key, const std::string& path) {
  const std::string k = "'" + key + "'";
  size_t p = h.find(k);
  if (p == std::string::npos) throw Error("npy " + path + ": header has no '" + key + "'");
  p = h.find(':', p + k.size());
  if (p == std::string::npos) throw Error("npy " + path + ": malformed header");
  ++p;
  while (p < h.size() && h[p] == ' ') ++p;
  size_t e = p;
  if (h[p] == '(') {
    e = h.find(')', p);
    if (e == std::string::npos) throw Error("npy " + path + ": malformed shape in header");
    return h.substr(p, e - p + 1);
  }
  while (e < h.size() && h[e] != ',' && h[e] != '}') ++e;
  return h.substr(p, e - p);
}

}  // namespace

std::vector<float> read_npy_features(const std::string& path, int64_t dim) {
  const std::string b = read_all(path, "npy");
  if (b.size() < 10 || std::memcmp(b.data(), "\x93NUMPY", 6) != 0) throw Error("npy " + path + ": not a .npy file");
  const int major = (unsigned char)b[6];
  size_t hlen = 0, hoff = 0;
  if (major == 1) {
    hlen = (unsigned char)b[8] | ((unsigned char)b[9] << 8), hoff = 10;
  } else if (major == 2 || major == 3) {
    if (b.size() < 12) throw Error("npy " + path + ": truncated header");
    uint32_t v;
    std::memcpy(&v, b.data() + 8, 4);
    hlen = v, hoff = 12;
  } else {
    throw Error("npy " + path + ": unsupported format version " + std::to_string(major));
  }
  if (hoff + hlen > b.size()) throw Error("npy " + path + ": truncated header");
  const std::string h = b.substr(hoff, hlen);
  const std::string descr = npy_field(h, "descr", path);
  const bool f4 = descr == "'<f4'", f8 = descr == "'<f8'";
  if (!f4 && !f8) throw Error("npy " + path + ": dtype " + descr + " is not '<f4' or '<f8'");
  if (npy_field(h, "fortran_order", path) != "False") throw Error("npy " + path + ": Fortran order is not supported");
  const std::string shape = npy_field(h, "shape", path);
  std::vector<int64_t> dims;
  {
    std::string s = shape.substr(1, shape.size() - 2);
    std::stringstream ss(s);
    std::string tok;
    while (std::getline(ss, tok, ',')) {
      size_t i = tok.find_first_not_of(' ');
      if (i == std::string::npos) continue;
      try {
        dims.push_back(std::stoll(tok.substr(i)));
      } catch (const std::exception&) {
        throw Error("npy " + path + ": bad shape " + shape);
      }
    }
  }
  if (dims.size() != 2 || dims[0] < 1 || dims[1] != dim)
    throw Error("npy " + path + ": shape " + shape + " is not (T, " + std::to_string(dim) + ") with T >= 1");
  const size_t n = (size_t)(dims[0] * dims[1]), esz = f4 ? 4 : 8, off = hoff + hlen;
  if (b.size() < off + n * esz)
    throw Error("npy " + path + ": truncated data (" + std::to_string(b.size() - off) + " bytes, expected " +
                std::to_string(n * esz) + ")");
  std::vector<float> out(n);
  if (f4) {
    std::memcpy(out.data(), b.data() + off, n * 4);
  } else {
    for (size_t i = 0; i < n; ++i) {
      double v;
      std::memcpy(&v, b.data() + off + i * 8, 8);
      out[i] = (float)v;
    }
  }
  for (size_t i = 0; i < n; ++i)
    if (!std::isfinite(out[i]))
      throw Error("npy " + path + ": non-finite value at frame " + std::to_string(i / dim) + ", dim " +
                  std::to_string(i % dim));
  return out;
}

void write_npy_features(const std::string& path, const std::vector<float>& rows, int64_t dim) {
  if (dim < 1 || rows.empty() || rows.size() % dim != 0)
    throw Error("npy " + path + ": " + std::to_string(rows.size()) + " values are not (T >= 1, " + std::to_string(dim) +
                ")");
  std::string h = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(rows.size() / dim) + ", " +
                  std::to_string(dim) + "), }";
  while ((10 + h.size() + 1) % 64 != 0) h += ' ';
  h += '\n';
  std::string b = "\x93NUMPY";
  b += (char)1;
  b += (char)0;
  b += (char)(h.size() & 0xff);
  b += (char)(h.size() >> 8);
  b += h;
  b.append(reinterpret_cast<const char*>(rows.data()), rows.size() * sizeof(float));
  nn::write_file_atomic(path, b);
}

MotionDir load_motion_dir(const std::string& dir) {
  const std::string jp = (fs::path(dir) / "motions.json").string();
  if (!fs::is_directory(dir)) throw Error("motions " + dir + ": not a directory");
  if (!fs::exists(jp)) throw Error("motions " + dir + ": no motions.json (see docs/TEXT.md for the format)");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_all(jp, "motions"));
  } catch (const nlohmann::json::exception& e) {
    throw Error("motions " + jp + ": bad JSON: " + e.what());
  }
  if (!j.is_object() || !j.contains("format") || j["format"] != "t2m-motions-1")
    throw Error("motions " + jp + ": format is not \"t2m-motions-1\"");
  if (!j.contains("motions") || !j["motions"].is_array() || j["motions"].empty())
    throw Error("motions " + jp + ": \"motions\" must be a non-empty list");
  MotionDir md;
  md.dir = dir;
  for (size_t i = 0; i < j["motions"].size(); ++i) {
    const auto& e = j["motions"][i];
    const std::string where = "motions " + jp + ": entry " + std::to_string(i);
    if (!e.is_object() || !e.contains("file") || !e["file"].is_string() || !e.contains("caption") ||
        !e["caption"].is_string() || e["caption"].get<std::string>().empty())
      throw Error(where + " needs a string \"file\" and a non-empty string \"caption\"");
    MotionEntry m;
    m.file = e["file"].get<std::string>();
    m.caption = e["caption"].get<std::string>();
    if (e.contains("prompt")) {
      if (!e["prompt"].is_number_integer() || e["prompt"].get<int64_t>() < 0)
        throw Error(where + ": \"prompt\" must be an integer >= 0");
      m.prompt = e["prompt"].get<int64_t>();
    }
    const fs::path rel(m.file);
    bool escapes = rel.is_absolute() || m.file.empty();
    for (const auto& part : rel)
      if (part == "..") escapes = true;
    if (escapes) throw Error(where + ": file '" + m.file + "' must be a relative path inside the directory");
    const std::string path = (fs::path(dir) / rel).string();
    if (!fs::is_regular_file(path)) throw Error(where + ": file '" + m.file + "' does not exist");
    const std::string ext = rel.extension().string();
    if (ext == ".npy") {
      m.features = read_npy_features(path, data::kFeatureDim);
    } else if (ext == ".bvh") {
      m.features = data::motion_to_features(sim::motion_from_bvh(sim::read_bvh(path)));
    } else {
      throw Error(where + ": file '" + m.file + "' is neither .npy nor .bvh");
    }
    m.frames = (int64_t)(m.features.size() / data::kFeatureDim);
    md.entries.push_back(std::move(m));
  }
  const auto groups = md.prompt_groups();
  for (const auto& g : groups)
    if (g.size() != groups[0].size() || g.size() < 2)
      throw Error("motions " + jp + ": every prompt needs the same number (>= 2) of samples; prompt of entry " +
                  std::to_string(g[0]) + " has " + std::to_string(g.size()) + ", another " +
                  std::to_string(groups[0].size()));
  return md;
}

std::vector<int64_t> MotionDir::main_set() const {
  std::vector<int64_t> out;
  std::map<int64_t, bool> seen;
  for (size_t i = 0; i < entries.size(); ++i) {
    const int64_t p = entries[i].prompt;
    if (p < 0 || !seen[p]) out.push_back((int64_t)i);
    if (p >= 0) seen[p] = true;
  }
  return out;
}

std::vector<std::vector<int64_t>> MotionDir::prompt_groups() const {
  std::map<int64_t, std::vector<int64_t>> g;
  for (size_t i = 0; i < entries.size(); ++i)
    if (entries[i].prompt >= 0) g[entries[i].prompt].push_back((int64_t)i);
  std::vector<std::vector<int64_t>> out;
  for (auto& kv : g) out.push_back(std::move(kv.second));
  return out;
}

}  // namespace t2m::eval
