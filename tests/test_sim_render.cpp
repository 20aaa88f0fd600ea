// test_sim_render.cpp — offscreen rendering (EGL surfaceless) of the humanoid, PNG and MP4 output.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "sim/render.h"
#include "tensor/tensor.h"

using namespace t2m::sim;

namespace {
std::unique_ptr<Renderer> try_renderer(std::shared_ptr<const Humanoid> h, RenderOptions o, std::string* why) {
  try {
    return std::make_unique<Renderer>(h, o);
  } catch (const t2m::Error& e) {
    *why = e.what();
    return nullptr;
  }
}
}  // namespace

TEST(SimRender, HumanoidIsVisibleAndMoves) {
  auto h = Humanoid::create();
  RenderOptions o;
  o.width = 96, o.height = 72;
  std::string why;
  auto r = try_renderer(h, o, &why);
  if (!r) GTEST_SKIP() << "no offscreen OpenGL here: " << why;
  std::vector<double> q(h->model()->qpos0, h->model()->qpos0 + h->model()->nq);
  std::vector<uint8_t> a(96 * 72 * 3), b(a.size());
  r->render(q.data(), a.data());
  // The image is not uniform (floor + body), and raising the left arm changes pixels.
  int distinct = 0;
  for (size_t i = 3; i < a.size(); i += 3) distinct += (a[i] != a[0] || a[i + 1] != a[1] || a[i + 2] != a[2]);
  EXPECT_GT(distinct, 1000);
  q[h->hinge_qpos(3 * (kUpperArmL - 1))] = 1.2;  // first hinge of UpperArm_L (x: sideways)
  r->render(q.data(), b.data());
  int changed = 0;
  for (size_t i = 0; i < a.size(); ++i) changed += a[i] != b[i];
  EXPECT_GT(changed, 30);
}

TEST(SimRender, WritesMp4AndPngs) {
  auto h = Humanoid::create();
  RenderOptions o;
  o.width = 64, o.height = 48;
  std::string why;
  if (!try_renderer(h, o, &why)) GTEST_SKIP() << "no offscreen OpenGL here: " << why;
  if (std::system("ffmpeg -version >/dev/null 2>&1") != 0) GTEST_SKIP() << "ffmpeg not installed";
  QposTrajectory q;
  q.frames = 4;
  q.nq = h->model()->nq;
  for (int t = 0; t < 4; ++t) q.qpos.insert(q.qpos.end(), h->model()->qpos0, h->model()->qpos0 + q.nq);
  const std::string dir = testing::TempDir() + "/t2m_render_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  EXPECT_EQ(render_trajectory(h, q, dir + "/out.mp4", dir + "/png", o), 4);
  EXPECT_GT(std::filesystem::file_size(dir + "/out.mp4"), 100u);
  EXPECT_FALSE(std::filesystem::exists(dir + "/out.mp4.tmp.mp4"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/png/frame_00000.png"));
  EXPECT_TRUE(std::filesystem::exists(dir + "/png/frame_00003.png"));
  std::ifstream f(dir + "/png/frame_00000.png", std::ios::binary);
  char sig[4] = {0};
  f.read(sig, 4);
  EXPECT_EQ(std::string(sig + 1, 3), "PNG");
  // Bad input: odd size, empty outputs, unwritable path.
  RenderOptions odd = o;
  odd.width = 63;
  EXPECT_THROW(Renderer(h, odd), t2m::Error);
  EXPECT_THROW(render_trajectory(h, q, "", "", o), t2m::Error);
  EXPECT_THROW(render_trajectory(h, q, "/nonexistent-dir/x.mp4", "", o), t2m::Error);
  std::filesystem::remove_all(dir);
}
