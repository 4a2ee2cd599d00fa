#include "sfm/reconstruction.h"

#include <algorithm>

namespace mound::sfm {

int Reconstruction::NumRegistered() const {
  return static_cast<int>(std::count(registered.begin(), registered.end(), true));
}

}  // namespace mound::sfm
