// mound_scene: the coarse search's scoring kernel. See cpp/scene/scene_cli.h.
#include <iostream>
#include <string>
#include <vector>

#include "scene/scene_cli.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return mound::scene::RunMoundScene(args, std::cout, std::cerr);
}
