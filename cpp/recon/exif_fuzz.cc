// libFuzzer target: the EXIF reader (JPEG APP1 segments and TIFF files, the photo card's
// GPS, time and camera). Any bytes: a result, never a crash or an out-of-bounds read; the
// facts it reports are in range.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "recon/exif.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::vector<uint8_t> bytes(data, data + size);
  const mound::recon::Exif e = mound::recon::ParseExif(bytes);
  if (e.lat_deg && !(std::abs(*e.lat_deg) <= 90)) std::abort();
  if (e.lon_deg && !(std::abs(*e.lon_deg) <= 180)) std::abort();
  if (!e.datetime.empty() && e.datetime.size() != 19) std::abort();
  if (e.width_px) (void)mound::recon::FocalPx(e, 640);
  if (e.dji) {
    const auto& d = *e.dji;
    for (const auto* v : {&d.abs_alt_m, &d.rel_alt_m, &d.gimbal_pitch_deg, &d.gimbal_yaw_deg,
                          &d.flight_yaw_deg, &d.rtk_std_lon_m, &d.rtk_std_lat_m, &d.rtk_std_hgt_m})
      if (*v && !(std::abs(**v) <= 20000)) std::abort();
  }
  return 0;
}
