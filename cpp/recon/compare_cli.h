// mound_recon compare and verdict (cpp/icp, cpp/terrain); see the usage in recon_cli.cc.
#pragma once

#include <string>
#include <vector>

namespace mound::recon {

int RunCompare(const std::vector<std::string>& args);
int RunVerdict(const std::vector<std::string>& args);

}  // namespace mound::recon
