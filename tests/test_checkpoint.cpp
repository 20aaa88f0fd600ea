// test_checkpoint.cpp — the checkpoint format: round trip, atomic writes, and every kind of bad file.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "nn/checkpoint.h"
#include "test_scratch_dir.h"

namespace fs = std::filesystem;
using namespace t2m;
using t2m::nn::Checkpoint;

namespace {

fs::path temp_dir() { return t2m::test::scratch_root(); }

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void write_all(const fs::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary);
  out << s;
}

// Expects `f` to throw t2m::Error whose message contains every needle.
template <typename F>
void expect_error(F f, std::initializer_list<const char*> needles) {
  try {
    f();
    FAIL() << "expected t2m::Error";
  } catch (const Error& e) {
    std::string m = e.what();
    for (const char* n : needles) EXPECT_NE(m.find(n), std::string::npos) << "message: " << m << " lacks: " << n;
  }
}

Checkpoint sample() {
  Checkpoint ck;
  ck.put("enc.weight", Tensor::from_vector(std::vector<float>{1, 2, 3, 4, 5, 6}, {2, 3}));
  ck.put("enc.bias", Tensor::from_vector(std::vector<double>{-1.5, 2.25}, {2}));
  ck.put("step_index", Tensor::from_vector(std::vector<int64_t>{7, 8, 9}, {3}));
  ck.put("empty", Tensor::zeros({0, 4}));
  // a non-contiguous view is stored as its logical contents
  ck.put("transposed", Tensor::from_vector(std::vector<float>{1, 2, 3, 4, 5, 6}, {2, 3}).transpose(0, 1));
  ck.meta = {{"step", 123}, {"rng", {{"seed", 42}, {"offset", 999}}}};
  return ck;
}

}  // namespace

TEST(Checkpoint, RoundTripKeepsNamesShapesDtypesValuesAndMeta) {
  fs::path p = temp_dir() / "a.ckpt";
  sample().save(p.string());
  Checkpoint ck = Checkpoint::load(p.string());
  ASSERT_EQ(ck.size(), 5u);
  EXPECT_EQ(ck.meta["step"].get<int>(), 123);
  EXPECT_EQ(ck.meta["rng"]["offset"].get<int>(), 999);
  EXPECT_EQ(ck.get("enc.weight").to_vector<float>(), (std::vector<float>{1, 2, 3, 4, 5, 6}));
  EXPECT_EQ(ck.get("enc.bias").dtype(), DType::f64);
  EXPECT_EQ(ck.get("enc.bias").to_vector<double>(), (std::vector<double>{-1.5, 2.25}));
  EXPECT_EQ(ck.get("step_index").to_vector<int64_t>(), (std::vector<int64_t>{7, 8, 9}));
  EXPECT_EQ(ck.get("empty").shape(), (Shape{0, 4}));
  EXPECT_EQ(ck.get("transposed").shape(), (Shape{3, 2}));
  EXPECT_EQ(ck.get("transposed").to_vector<float>(), (std::vector<float>{1, 4, 2, 5, 3, 6}));
  // saving the loaded checkpoint again gives the identical file (deterministic format)
  fs::path q = temp_dir() / "b.ckpt";
  ck.save(q.string());
  EXPECT_EQ(read_all(p), read_all(q));
}

TEST(Checkpoint, ExpectChecksShapeAndDtype) {
  Checkpoint ck = sample();
  EXPECT_NO_THROW(ck.expect("enc.weight", {2, 3}, DType::f32));
  expect_error([&] { ck.expect("enc.weight", {3, 3}, DType::f32); }, {"enc.weight", "[2, 3]", "[3, 3]"});
  expect_error([&] { ck.expect("enc.weight", {2, 3}, DType::f64); }, {"enc.weight", "f64"});
  expect_error([&] { ck.get("nope"); }, {"nope"});
}

TEST(Checkpoint, TruncatedFileAtEveryLengthGivesAClearError) {
  fs::path p = temp_dir() / "t.ckpt";
  sample().save(p.string());
  std::string full = read_all(p);
  fs::path bad = temp_dir() / "t_bad.ckpt";
  for (size_t len = 0; len < full.size(); len += 1 + len / 7) {
    write_all(bad, full.substr(0, len));
    expect_error([&] { Checkpoint::load(bad.string()); }, {"checkpoint", "t_bad.ckpt"});
  }
}

TEST(Checkpoint, CorruptedByteIsDetectedByTheChecksum) {
  fs::path p = temp_dir() / "c.ckpt";
  sample().save(p.string());
  std::string full = read_all(p);
  // flip one bit in the tensor data region (well past the header, before the trailer)
  std::string bad = full;
  bad[bad.size() - 40] ^= 0x10;
  write_all(p, bad);
  expect_error([&] { Checkpoint::load(p.string()); }, {"checksum"});
}

TEST(Checkpoint, WrongMagicVersionAndMissingFile) {
  fs::path p = temp_dir() / "m.ckpt";
  sample().save(p.string());
  std::string full = read_all(p);
  std::string bad = full;
  bad[0] = 'X';
  write_all(p, bad);
  expect_error([&] { Checkpoint::load(p.string()); }, {"magic"});
  bad = full;
  bad[8] = 9;  // version field
  write_all(p, bad);
  expect_error([&] { Checkpoint::load(p.string()); }, {"version 9"});
  expect_error([&] { Checkpoint::load((temp_dir() / "does_not_exist.ckpt").string()); }, {"does_not_exist", "open"});
}

TEST(Checkpoint, AtomicSaveLeavesNoTempFileAndKeepsTheOldFileOnFailure) {
  fs::path d = temp_dir() / "atomic";
  fs::create_directories(d);
  fs::path p = d / "x.ckpt";
  sample().save(p.string());
  std::string before = read_all(p);
  for (const auto& e : fs::directory_iterator(d)) EXPECT_EQ(e.path().filename(), "x.ckpt");
  // an unwritable destination (a directory in the way of the rename target's temp) fails cleanly
  expect_error([&] { sample().save((d / "no_such_dir" / "y.ckpt").string()); }, {"no_such_dir"});
  EXPECT_EQ(read_all(p), before);
}

TEST(Checkpoint, Crc32cKnownAnswer) {
  // CRC-32C of "123456789" is 0xE3069283 (the standard check value of the Castagnoli polynomial).
  EXPECT_EQ(t2m::nn::crc32c("123456789", 9), 0xE3069283u);
  // incremental == one shot
  uint32_t c = t2m::nn::crc32c("12345", 5);
  EXPECT_EQ(t2m::nn::crc32c("6789", 4, c), 0xE3069283u);
}
