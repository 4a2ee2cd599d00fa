// mound_recon: the 3-D stage. See cpp/recon/recon_cli.h.
#include <iostream>
#include <string>
#include <vector>

#include "recon/recon_cli.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return mound::recon::RunMoundRecon(args, std::cout, std::cerr);
}
