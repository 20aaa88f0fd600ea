// atomic_file.h — what sim/'s writers (BVH, NAME.qpos.json, NAME.ctrl.json) share: a text file written whole or
// not at all (temp file next to it, then rename), so an interrupted or failed write never leaves a half-written
// file under the final name. (nn/ has its own write_file_atomic; sim/ depends on no learning code.)
#pragma once
#include <string>

namespace t2m::sim {

// Writes `text` to path.tmp.<pid> and renames it onto path. On any failure the temp file is removed and t2m::Error
// says "<who>: cannot write '<path>' (<reason>)"; an existing file at path is then left as it was.
void write_text_atomic(const std::string& path, const std::string& text, const char* who);

}  // namespace t2m::sim
