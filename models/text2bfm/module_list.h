// module_list.h — an indexed list of child modules named "0", "1", ... (torch's nn.ModuleList naming), so that
// parameters come out as "blocks.0.attn.qkv.weight" like the anchor's. Holds no parameters of its own.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "nn/module.h"

namespace t2m::text2bfm {

template <typename M>
class ModuleList : public nn::Module {
 public:
  explicit ModuleList(const std::vector<std::shared_ptr<M>>& items) {
    for (size_t i = 0; i < items.size(); ++i) register_module(std::to_string(i), items[i]);
  }
};

}  // namespace t2m::text2bfm
