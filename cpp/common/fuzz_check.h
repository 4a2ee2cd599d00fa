// What every fuzz target asserts: a reader answers any input either with a value or with
// InputError (the tools' exit 2, one line). Anything else — another exception type (exit
// 1, "a bug"), a crash, a sanitizer report, a hang or a runaway allocation — is a finding.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "common/error.h"

namespace mound::fuzz {

template <typename F>
void ExpectValueOrInputError(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    const std::string what = e.what();
    if (what.empty() || what.find('\n') != std::string::npos) {
      std::fprintf(stderr, "InputError must be one non-empty line, got '%s'\n", what.c_str());
      std::abort();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "not an InputError (the tool would exit 1): %s\n", e.what());
    std::abort();
  }
}

}  // namespace mound::fuzz
