// mound_scene: the coarse search's compiled scoring kernel, one block per call (the
// command-line layer only; the kernel is scene/multiscale.h).
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace mound::scene {

int RunMoundScene(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace mound::scene
