// mound_render: the site simulator's renderer. See cpp/sim/render_cli.h.
#include <iostream>
#include <string>
#include <vector>

#include "sim/render_cli.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return mound::sim::RunMoundRender(args, std::cout, std::cerr);
}
