// test_dataset.cpp — data set plumbing: clip names, label files, .tar.zst extraction (archives built here with a
// tar writer written in this file + libzstd), manifest build / save / load on a mini data set made from the
// fixtures, prepare_dataset's unpack-once behaviour, and (when present) the real dataset-1 archive.
#include <gtest/gtest.h>
#include <unistd.h>
#include <zstd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "models/data/dataset.h"
#include "tensor/tensor.h"

using namespace t2m;
using namespace t2m::data;
namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
void spit(const fs::path& p, const std::string& s) {
  fs::create_directories(p.parent_path());
  std::ofstream f(p, std::ios::binary);
  f << s;
}
std::string fixture(const std::string& name) { return slurp(std::string(T2M_SOURCE_DIR) + "/tests/fixtures/bvh/" + name); }

// A fresh temporary directory, removed at the end of the test.
struct TempDir {
  fs::path path;
  explicit TempDir(const std::string& tag) {
    path = fs::path(::testing::TempDir()) / ("t2m_dataset_" + tag + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~TempDir() { fs::remove_all(path); }
};

// Appends one ustar entry (header + data padded to 512).
void tar_entry(std::string& tar, const std::string& name, char type, const std::string& data) {
  char h[512] = {0};
  std::snprintf(h, 100, "%s", name.c_str());
  std::snprintf(h + 100, 8, "%07o", 0644);
  std::snprintf(h + 108, 8, "%07o", 0);
  std::snprintf(h + 116, 8, "%07o", 0);
  std::snprintf(h + 124, 12, "%011o", (unsigned)data.size());
  std::snprintf(h + 136, 12, "%011o", 0);
  h[156] = type;
  std::memcpy(h + 257, "ustar\0" "00", 8);
  std::memset(h + 148, ' ', 8);
  unsigned sum = 0;
  for (unsigned char c : h) sum += c;
  std::snprintf(h + 148, 8, "%06o", sum);
  h[155] = ' ';
  tar.append(h, 512);
  tar += data;
  tar.append((512 - data.size() % 512) % 512, '\0');
}
std::string tar_end(std::string tar) { return tar.append(1024, '\0'); }

std::string zstd_compress(const std::string& s) {
  std::string out(ZSTD_compressBound(s.size()), '\0');
  const size_t n = ZSTD_compress(out.data(), out.size(), s.data(), s.size(), 3);
  EXPECT_FALSE(ZSTD_isError(n));
  out.resize(n);
  return out;
}

// A mini data dir: cfg labels + dataset-1.tar.zst with the real fixture clip under two names and bad clips.
void make_mini_data(const fs::path& dir) {
  spit(dir / "cfg/dataset-1_content_label.txt", "dataset-1_walk\r\ndataset-1_run\n\n");
  spit(dir / "cfg/dataset-1_style_label.txt", "dataset-1_normal\ndataset-1_happy\n");
  spit(dir / "cfg/dataset-2_content_label.txt", "dataset-2_walk\n");
  spit(dir / "cfg/dataset-2_style_label.txt", "dataset-2_active\n");
  const std::string d = "Bandai-Namco-Research-Motiondataset-1/data/";
  const std::string walk = fixture("bandai_walk_60.bvh");
  std::string tar;
  tar_entry(tar, d, '5', "");
  tar_entry(tar, d + "dataset-1_walk_normal_001.bvh", '0', walk);
  tar_entry(tar, d + "dataset-1_walk_normal_001.json", '0', "{\"content\": 0, \"style\": 0}");
  tar_entry(tar, d + "dataset-1_run_happy_002.bvh", '0', walk);
  tar_entry(tar, d + "dataset-1_run_happy_002.json", '0', "{\"content\": 1, \"style\": 1}");
  tar_entry(tar, d + "dataset-1_run_normal_001.bvh", '0', fixture("chain3.bvh"));  // not the canonical skeleton
  tar_entry(tar, d + "dataset-1_run_normal_001.json", '0', "{\"content\": 1, \"style\": 0}");
  tar_entry(tar, d + "dataset-1_walk_happy_001.bvh", '0', walk);  // json disagrees with the name
  tar_entry(tar, d + "dataset-1_walk_happy_001.json", '0', "{\"content\": 1, \"style\": 1}");
  tar_entry(tar, d + "dataset-1_walk_happy_003.bvh", '0', walk);  // no json
  tar_entry(tar, d + "dataset-1_walk_happy_004.bvh", '0', walk.substr(0, walk.size() / 2));  // truncated
  tar_entry(tar, d + "dataset-1_walk_happy_004.json", '0', "{\"content\": 0, \"style\": 1}");
  spit(dir / "dataset-1.tar.zst", zstd_compress(tar_end(tar)));
}

}  // namespace

TEST(Dataset, ParsesClipNames) {
  int ds = 0, take = 0;
  std::string c, s;
  ASSERT_TRUE(parse_clip_name("dataset-2_walk-turn-left_active_013", &ds, &c, &s, &take));
  EXPECT_EQ(ds, 2);
  EXPECT_EQ(c, "walk-turn-left");
  EXPECT_EQ(s, "active");
  EXPECT_EQ(take, 13);
  ASSERT_TRUE(parse_clip_name("dataset-1_walk_not-confident_001", &ds, &c, &s, &take));
  EXPECT_EQ(s, "not-confident");
  for (const char* bad : {"dataset-3_walk_active_001", "dataset-2_walk_active", "dataset-2_walk_active_01x",
                          "dataset-2__active_001", "dataset-2_a_b_c_001", "", "walk"})
    EXPECT_FALSE(parse_clip_name(bad, &ds, &c, &s, &take)) << bad;
  EXPECT_EQ(clip_content("dataset-2_walk-turn-left_active_013"), "walk-turn-left");
  EXPECT_EQ(clip_content("dataset-2__active_001"), "");
  EXPECT_EQ(clip_content("bandai_walk_60"), "");
}

TEST(Dataset, ReadsLabelFiles) {
  TempDir t("labels");
  spit(t.path / "l.txt", "a\r\n\nb \nc");
  EXPECT_EQ(read_label_file((t.path / "l.txt").string()), (std::vector<std::string>{"a", "b", "c"}));
  EXPECT_THROW(read_label_file((t.path / "missing.txt").string()), Error);
}

TEST(Dataset, ExtractsTarZstWithDirsLongNamesAndEmptyFiles) {
  TempDir t("extract");
  const std::string long_name = "deep/" + std::string(150, 'n') + ".txt";
  std::string tar;
  tar_entry(tar, "top/", '5', "");
  tar_entry(tar, "top/a.txt", '0', "hello");
  tar_entry(tar, "top/empty", '0', "");
  tar_entry(tar, "././@LongLink", 'L', long_name + std::string(1, '\0'));
  tar_entry(tar, "truncated-name", '0', std::string(1000, 'x'));
  tar_entry(tar, "top/link", '2', "");  // symlink: skipped
  spit(t.path / "a.tar.zst", zstd_compress(tar_end(tar)));
  const int n = extract_tar_zst((t.path / "a.tar.zst").string(), (t.path / "out").string());
  EXPECT_EQ(n, 3);
  EXPECT_EQ(slurp(t.path / "out/top/a.txt"), "hello");
  EXPECT_TRUE(fs::exists(t.path / "out/top/empty"));
  EXPECT_EQ(fs::file_size(t.path / "out/top/empty"), 0u);
  EXPECT_EQ(slurp(t.path / "out" / long_name), std::string(1000, 'x'));
  EXPECT_FALSE(fs::exists(t.path / "out/top/link"));
  EXPECT_FALSE(fs::exists(t.path / "out/truncated-name"));
}

TEST(Dataset, ExtractRejectsBadArchives) {
  TempDir t("badtar");
  std::string tar;
  tar_entry(tar, "f.txt", '0', std::string(700, 'y'));
  const std::string good = tar_end(tar);
  auto expect_error = [&](const std::string& bytes, const std::string& want) {
    spit(t.path / "x.tar.zst", bytes);
    try {
      extract_tar_zst((t.path / "x.tar.zst").string(), (t.path / "out").string());
      ADD_FAILURE() << "no throw, want " << want;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(want), std::string::npos) << e.what();
    }
  };
  std::string bad_sum = good;
  bad_sum[0] = 'g';
  expect_error(zstd_compress(bad_sum), "checksum");
  expect_error(zstd_compress(good.substr(0, 800)), "truncated");
  const std::string z = zstd_compress(good);
  expect_error(z.substr(0, z.size() - 5), "truncated");
  expect_error("this is not zstd at all", "zstd error");
  std::string evil;
  tar_entry(evil, "../evil.txt", '0', "x");
  expect_error(zstd_compress(tar_end(evil)), "unsafe entry");
  std::string abs;
  tar_entry(abs, "/tmp/evil.txt", '0', "x");
  expect_error(zstd_compress(tar_end(abs)), "unsafe entry");
  EXPECT_FALSE(fs::exists(t.path / "evil.txt"));
  EXPECT_THROW(extract_tar_zst((t.path / "missing.tar.zst").string(), (t.path / "out").string()), Error);
}

TEST(Dataset, BuildsManifestAndSkipsUnreadableClips) {
  TempDir t("manifest");
  make_mini_data(t.path / "data");
  const std::string root = unpack_dataset((t.path / "data").string(), (t.path / "cache").string());
  EXPECT_EQ(fs::path(root), t.path / "cache/bandai");
  EXPECT_TRUE(fs::exists(t.path / "cache/bandai/.unpacked-dataset-1"));
  Manifest m = build_manifest(root, (t.path / "data").string(), 2);
  ASSERT_EQ(m.clips.size(), 2u);
  EXPECT_EQ(m.content_labels[0], (std::vector<std::string>{"walk", "run"}));
  EXPECT_EQ(m.style_labels[1], (std::vector<std::string>{"active"}));
  const ClipInfo& r = m.clips[0];  // sorted by name
  EXPECT_EQ(r.name, "dataset-1_run_happy_002");
  EXPECT_EQ(r.dataset, 1);
  EXPECT_EQ(r.content, 1);
  EXPECT_EQ(r.style, 1);
  EXPECT_EQ(r.content_label, "run");
  EXPECT_EQ(r.style_label, "happy");
  EXPECT_EQ(r.take, 2);
  EXPECT_EQ(r.frames, 60);
  EXPECT_NEAR(r.duration, 2.0, 1e-4);
  EXPECT_EQ(m.clips[1].name, "dataset-1_walk_normal_001");
  EXPECT_NEAR(m.total_duration(), 4.0, 1e-3);
  ASSERT_EQ(m.skipped.size(), 4u);
  auto skipped_for = [&](const std::string& name) {
    for (const auto& s : m.skipped)
      if (s.rfind(name + ": ", 0) == 0) return s;
    return std::string();
  };
  EXPECT_NE(skipped_for("dataset-1_run_normal_001").find("lacks canonical joints"), std::string::npos);
  EXPECT_NE(skipped_for("dataset-1_walk_happy_001").find("disagrees with the name"), std::string::npos);
  EXPECT_NE(skipped_for("dataset-1_walk_happy_003").find("missing dataset-1_walk_happy_003.json"), std::string::npos);
  EXPECT_NE(skipped_for("dataset-1_walk_happy_004").find("truncated"), std::string::npos);
  // The clip loads as a canonical Motion.
  sim::Motion mo = load_clip(r);
  EXPECT_EQ(mo.frames, 60);

  // Save / load round trip; bvh paths are stored relative to the manifest, so the cache can move.
  const std::string mp = (t.path / "cache/bandai/manifest.json").string();
  save_manifest(m, mp);
  EXPECT_NE(slurp(mp).find("\"Bandai-Namco-Research-Motiondataset-1/data/dataset-1_run_happy_002.bvh\""),
            std::string::npos);
  fs::rename(t.path / "cache", t.path / "moved");
  Manifest l = load_manifest((t.path / "moved/bandai/manifest.json").string());
  ASSERT_EQ(l.clips.size(), 2u);
  EXPECT_EQ(l.clips[0].name, r.name);
  EXPECT_EQ(l.clips[0].frames, r.frames);
  EXPECT_EQ(l.clips[0].style_label, r.style_label);
  EXPECT_EQ(l.skipped, m.skipped);
  EXPECT_EQ(l.content_labels[0], m.content_labels[0]);
  EXPECT_EQ(load_clip(l.clips[0]).frames, 60);
  spit(t.path / "garbage.json", "{\"version\": 1, \"clips\": [");
  EXPECT_THROW(load_manifest((t.path / "garbage.json").string()), Error);
  spit(t.path / "v2.json", "{\"version\": 2}");
  EXPECT_THROW(load_manifest((t.path / "v2.json").string()), Error);
  EXPECT_THROW(load_manifest((t.path / "none.json").string()), Error);
  EXPECT_THROW(build_manifest((t.path / "none").string(), ""), Error);
}

TEST(Dataset, PrepareUnpacksOnceAndReusesTheManifest) {
  TempDir t("prepare");
  make_mini_data(t.path / "data");
  Manifest a = prepare_dataset((t.path / "data").string(), (t.path / "cache").string());
  EXPECT_EQ(a.clips.size(), 2u);
  const fs::path clip = t.path / "cache/bandai/Bandai-Namco-Research-Motiondataset-1/data/dataset-1_walk_normal_001.json";
  spit(clip, "{\"content\": 0, \"style\": 0, \"edited\": true}");  // would be overwritten by a second unpack
  Manifest b = prepare_dataset((t.path / "data").string(), (t.path / "cache").string());
  EXPECT_EQ(b.clips.size(), 2u);
  EXPECT_NE(slurp(clip).find("edited"), std::string::npos);
  // A changed archive (different size) is unpacked again; force rebuilds the manifest.
  std::string tar;
  tar_entry(tar, "Bandai-Namco-Research-Motiondataset-1/data/dataset-1_walk_normal_001.json", '0',
            "{\"content\": 0, \"style\": 0}");
  spit(t.path / "data/dataset-1.tar.zst", zstd_compress(tar_end(tar)));
  Manifest c = prepare_dataset((t.path / "data").string(), (t.path / "cache").string(), true);
  EXPECT_EQ(slurp(clip).find("edited"), std::string::npos);
  EXPECT_EQ(c.clips.size(), 2u);
  EXPECT_THROW(unpack_dataset((t.path / "nodata").string(), (t.path / "cache").string()), Error);
}

TEST(Dataset, DefaultDirectoriesFollowTheEnvironment) {
  const char* old = std::getenv("T2M_CACHE");
  std::string saved = old ? old : "";
  setenv("T2M_CACHE", "/some/cache", 1);
  EXPECT_EQ(default_cache_dir(), "/some/cache");
  unsetenv("T2M_CACHE");
  const char* home = std::getenv("HOME");
  if (home) {
    EXPECT_EQ(default_cache_dir(), std::string(home) + "/.cache/t2m");
  }
  if (old) setenv("T2M_CACHE", saved.c_str(), 1);
  const char* od = std::getenv("T2M_DATA");
  std::string saved_d = od ? od : "";
  setenv("T2M_DATA", "/some/data", 1);
  EXPECT_EQ(default_data_dir(), "/some/data");
  if (od) {
    setenv("T2M_DATA", saved_d.c_str(), 1);
  } else {
    unsetenv("T2M_DATA");
  }
}

TEST(Dataset, RealDataset1UnpacksAndEveryClipParses) {
  const char* env = std::getenv("T2M_DATA");
  const fs::path data = env && *env ? fs::path(env) : fs::path(T2M_SOURCE_DIR) / "../shared/data/bandai";
  if (!fs::exists(data / "dataset-1.tar.zst")) GTEST_SKIP() << "no " << (data / "dataset-1.tar.zst");
  TempDir t("real");
  const int files = extract_tar_zst((data / "dataset-1.tar.zst").string(), (t.path / "bandai").string());
  EXPECT_EQ(files, 2 * 174 + 1);  // 174 .bvh + .json, plus the lone .json of the absent dance-long_normal_001
  Manifest m = build_manifest((t.path / "bandai").string(), data.string());
  EXPECT_EQ(m.clips.size(), 174u);
  EXPECT_TRUE(m.skipped.empty()) << m.skipped.front();
  EXPECT_EQ(m.content_labels[0].size(), 17u);
  EXPECT_EQ(m.style_labels[0].size(), 15u);
  for (const auto& c : m.clips) {
    EXPECT_NE(c.name, "dataset-1_dance-long_normal_001");  // documented as absent
    EXPECT_EQ(c.content_label, m.content_labels[0][c.content]);
    EXPECT_GT(c.frames, 0);
  }
  EXPECT_GT(m.total_duration(), 10 * 60.0);
}

TEST(Dataset, MutatedArchivesExtractOrThrowError) {
  // Byte-level mutants of a small tar (then compressed) and of the compressed stream: extraction must succeed or
  // throw t2m::Error, and must never write outside the destination.
  TempDir t("tarfuzz");
  std::string tar;
  tar_entry(tar, "d/", '5', "");
  tar_entry(tar, "d/a.txt", '0', std::string(600, 'a'));
  tar_entry(tar, "././@LongLink", 'L', std::string("d/") + std::string(120, 'l') + std::string(1, '\0'));
  tar_entry(tar, "x", '0', "b");
  const std::string base = tar_end(tar);
  std::mt19937 rng(5);
  int ok = 0, rejected = 0;
  for (int i = 0; i < 200; ++i) {
    std::string s = base;
    for (int k = 0, n = 1 + (int)(rng() % 4); k < n; ++k) s[rng() % s.size()] = (char)rng();
    std::string z = zstd_compress(s);
    if (i % 4 == 3) z[rng() % z.size()] ^= (char)(1 + rng() % 255);
    spit(t.path / "m.tar.zst", z);
    try {
      extract_tar_zst((t.path / "m.tar.zst").string(), (t.path / "out").string());
      ++ok;
    } catch (const Error&) {
      ++rejected;
    }
  }
  EXPECT_GT(ok, 0);
  EXPECT_GT(rejected, 0);
  for (const auto& e : fs::directory_iterator(t.path))
    EXPECT_TRUE(e.path().filename() == "out" || e.path().filename() == "m.tar.zst") << e.path();
}
