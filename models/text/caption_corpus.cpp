// caption_corpus.cpp — caption texts of one split for building the vocabulary.
#include "models/text/caption_corpus.h"

#include "models/data/captions.h"
#include "tensor/tensor.h"

namespace t2m::text {

std::vector<std::string> split_caption_corpus(const std::map<std::string, data::Split>& splits, data::Split which,
                                              const CaptionCorpusOptions& opt) {
  if (opt.paraphrases < 1)
    throw Error("split_caption_corpus: paraphrases must be >= 1 (got " + std::to_string(opt.paraphrases) + ")");
  std::vector<std::string> corpus, firsts;
  for (const auto& name : data::clips_in(splits, which)) {
    data::ClipName c = data::clip_name_parts(name);
    if (!data::has_caption_content(c.content) || !data::has_caption_style(c.style))
      throw Error("split_caption_corpus: clip " + name + " has labels without caption words (content '" +
                  c.content + "', style '" + c.style + "')");
    auto texts = data::caption_paraphrases(c.content, c.style, opt.seed, opt.paraphrases, false);
    firsts.push_back(texts.front());
    corpus.insert(corpus.end(), texts.begin(), texts.end());
    if (opt.mirrored) {
      auto m = data::caption_paraphrases(c.content, c.style, opt.seed, opt.paraphrases, true);
      corpus.insert(corpus.end(), m.begin(), m.end());
    }
  }
  if (opt.compositions)
    for (size_t i = 0; i + 1 < firsts.size(); ++i) corpus.push_back(data::compose_captions(firsts[i], firsts[i + 1]));
  return corpus;
}

}  // namespace t2m::text
