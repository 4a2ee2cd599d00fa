// mound_recon densify (cpp/mvs): dense.ply and dense.json from a georeferenced model; see
// the usage in recon_cli.cc.
#pragma once

#include <string>
#include <vector>

namespace mound::recon {

int RunDensify(const std::vector<std::string>& args);

}  // namespace mound::recon
