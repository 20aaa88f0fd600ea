// compose_eval.cpp — N-clause prompts from split clips, Compose clause bounds, and the Table 2 scoring loop.
#include "models/text2bfm/compose_eval.h"

#include <chrono>
#include <ctime>
#include <cmath>
#include <exception>
#include <map>
#include <mutex>
#include <set>

#include "models/data/captions.h"
#include "models/data/features.h"
#include "models/eval/compositional.h"
#include "models/text/tokenizer.h"
#include "models/text2bfm/compose.h"
#include "models/text2bfm/eval_generation.h"
#include "sim/env.h"
#include "tensor/rng.h"

namespace t2m::text2bfm {

namespace {

double process_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

}  // namespace

std::vector<ComposePrompt> make_compose_prompts(const std::vector<data::MotionClip>& clips, int64_t N, int64_t count,
                                                uint64_t seed) {
  if (N < 2) throw Error("compose eval: N must be >= 2, got " + std::to_string(N));
  if (count < 1) throw Error("compose eval: count must be >= 1");
  std::set<std::string> labels;
  for (const auto& c : clips) labels.insert(c.content);
  if ((int64_t)labels.size() < N)
    throw Error("compose eval: " + std::to_string(labels.size()) + " distinct content labels, need " +
                std::to_string(N));
  std::vector<ComposePrompt> out;
  for (int64_t p = 0; p < count; ++p) {
    bool ok = false;
    for (int attempt = 0; attempt < 100 && !ok; ++attempt) {
      Generator g(sample_seed(seed, p, attempt));
      const std::vector<int64_t> perm = randperm((int64_t)clips.size(), g);
      ComposePrompt cp;
      std::set<std::string> used;
      for (int64_t i : perm) {
        if (used.count(clips[i].content)) continue;
        used.insert(clips[i].content);
        cp.clips.push_back(clips[i].name);
        cp.clauses.push_back(data::make_caption(clips[i].content, clips[i].style, 7, 0).text);
        if ((int64_t)cp.clauses.size() == N) break;
      }
      for (size_t n = 0; n < cp.clauses.size(); ++n) cp.prompt.append(n ? ", then " : "").append(cp.clauses[n]);
      std::vector<std::string> norm;
      for (const auto& c : cp.clauses) norm.push_back(text::normalize(c));
      ok = split_clauses(cp.prompt) == norm;
      if (ok) out.push_back(std::move(cp));
    }
    if (!ok) throw Error("compose eval: no prompt of " + std::to_string(N) + " clauses splits cleanly (prompt " +
                         std::to_string(p) + ")");
  }
  return out;
}

std::vector<int64_t> compose_bounds(int64_t T, int64_t N, int64_t O, int64_t c) {
  if (N < 1 || T < N || O < 0 || c < 1)
    throw Error("compose eval: bad compose_bounds(T " + std::to_string(T) + ", N " + std::to_string(N) + ", O " +
                std::to_string(O) + ", c " + std::to_string(c) + ")");
  const int64_t per = (T + (N - 1) * O + N - 1) / N;
  const int64_t Tn = ((per + c - 1) / c) * c;
  std::vector<int64_t> b{0};
  for (int64_t k = 1; k < N; ++k) {
    int64_t x = k * (Tn - O) + O / 2;
    x = std::max(x, b.back() + 1);
    x = std::min(x, T - (N - k));
    b.push_back(x);
  }
  b.push_back(T);
  return b;
}

ComposeRow evaluate_compose(Text2BfmModels& m, const text::RetrievalBundle& evaluator,
                            const std::vector<ComposePrompt>& prompts, const ComposeEvalOptions& opt, bool compose) {
  if (prompts.empty()) throw Error("compose eval: no prompts");
  if (opt.frames_per_clause < 1) throw Error("compose eval: frames_per_clause must be >= 1");
  if (opt.jobs < 1) throw Error("compose eval: jobs must be >= 1");
  const int64_t P = (int64_t)prompts.size(), N = (int64_t)prompts[0].clauses.size();
  for (const auto& p : prompts)
    if ((int64_t)p.clauses.size() != N) throw Error("compose eval: prompts with different clause counts");
  const int64_t T = N * opt.frames_per_clause, c = m.vbb->config().compression();
  const std::vector<int64_t> bounds =
      compose ? compose_bounds(T, N, opt.gen.overlap, c) : eval::segment_bounds_uniform(T, N);
  std::vector<std::vector<float>> feats((size_t)P);
  std::vector<int> fell((size_t)P, 0);
  const auto t0 = std::chrono::steady_clock::now();
  const double c0 = process_cpu_s();
  std::mutex mu;
  std::exception_ptr err;
#pragma omp parallel for schedule(dynamic, 1) num_threads(opt.jobs)
  for (int64_t p = 0; p < P; ++p) {
    try {
      GenerateOptions go = opt.gen;
      go.seed = sample_seed(opt.seed, p, 0);
      go.length_s = double(T) * sim::kControlDt;
      go.compose = compose;
      const Generation g = generate_motion(m, prompts[p].prompt, go);
      feats[p] = trajectory_features(*m.humanoid, g.traj, 1);
      fell[p] = g.falls > 0;
    } catch (...) {
      std::lock_guard<std::mutex> lk(mu);
      if (!err) err = std::current_exception();
    }
  }
  if (err) std::rethrow_exception(err);
  ComposeRow r;
  r.method = compose ? "Text2BFM-Compose" : "Text2BFM";
  r.N = N, r.prompts = P;
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  r.cpu_s = process_cpu_s() - c0;
  // Segments [P * N] and clauses [P * N], embedded in one go each.
  std::vector<std::vector<float>> segs;
  std::vector<std::string> texts;
  for (int64_t p = 0; p < P; ++p)
    for (int64_t n = 0; n < N; ++n) {
      const auto& f = feats[p];
      segs.emplace_back(f.begin() + bounds[n] * data::kFeatureDim, f.begin() + bounds[n + 1] * data::kFeatureDim);
      texts.push_back(prompts[p].clauses[n]);
    }
  std::vector<const std::vector<float>*> sp;
  for (const auto& s : segs) sp.push_back(&s);
  const Tensor se = text::embed_motions(evaluator, sp), te = text::embed_texts(evaluator, texts);
  int64_t correct = 0;
  double mm = 0, tr = 0;
  for (int64_t p = 0; p < P; ++p) {
    const Tensor s = se.narrow(0, p * N, N), t = te.narrow(0, p * N, N);
    correct += eval::order_correct(s, t) ? 1 : 0;
    mm += eval::segment_mm_dist(s, t);
    tr += eval::transition_score(feats[p], bounds);
    r.fell += fell[p];
  }
  r.order_accuracy = double(correct) / double(P);
  r.mm_dist = mm / double(P);
  r.transition = tr / double(P);
  return r;
}

ComposeRow evaluate_real_segments(const text::RetrievalBundle& evaluator, const std::vector<ComposePrompt>& prompts,
                                  const std::vector<data::MotionClip>& clips, int64_t frames_per_clause) {
  if (prompts.empty()) throw Error("compose eval: no prompts");
  std::map<std::string, const data::MotionClip*> by_name;
  for (const auto& c : clips) by_name[c.name] = &c;
  const int64_t P = (int64_t)prompts.size(), N = (int64_t)prompts[0].clauses.size();
  std::vector<std::vector<float>> segs;
  std::vector<std::string> texts;
  for (const auto& p : prompts)
    for (int64_t n = 0; n < N; ++n) {
      const auto it = by_name.find(p.clips.at(n));
      if (it == by_name.end()) throw Error("compose eval: clip " + p.clips[n] + " not found");
      const auto& f = it->second->features;
      const int64_t T = (int64_t)f.size() / data::kFeatureDim, L = std::min(T, frames_per_clause);
      const int64_t s0 = (T - L) / 2;
      segs.emplace_back(f.begin() + s0 * data::kFeatureDim, f.begin() + (s0 + L) * data::kFeatureDim);
      texts.push_back(p.clauses[n]);
    }
  std::vector<const std::vector<float>*> sp;
  for (const auto& s : segs) sp.push_back(&s);
  const Tensor se = text::embed_motions(evaluator, sp), te = text::embed_texts(evaluator, texts);
  ComposeRow r;
  r.method = "real clips (metric ceiling)";
  r.N = N, r.prompts = P;
  int64_t correct = 0;
  double mm = 0;
  for (int64_t p = 0; p < P; ++p) {
    const Tensor s = se.narrow(0, p * N, N), t = te.narrow(0, p * N, N);
    correct += eval::order_correct(s, t) ? 1 : 0;
    mm += eval::segment_mm_dist(s, t);
  }
  r.order_accuracy = double(correct) / double(P);
  r.mm_dist = mm / double(P);
  r.transition = std::nan("");
  return r;
}

}  // namespace t2m::text2bfm
