// mound_plan: orienteering tour planner and TSPLIB solver. See cpp/plan/plan_cli.h.
#include <iostream>
#include <string>
#include <vector>

#include "plan/plan_cli.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return mound::plan::RunMoundPlan(args, std::cout, std::cerr);
}
