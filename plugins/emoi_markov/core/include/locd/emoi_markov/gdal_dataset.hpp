// GDAL, registered once, and an owning dataset handle: what the DSM reader and the tools' DSM
// writers share.
#pragma once

#include <gdal_priv.h>

#include <memory>
#include <mutex>

namespace locd::emoi {

inline void register_gdal() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};
using Dataset = std::unique_ptr<GDALDataset, DatasetCloser>;

}  // namespace locd::emoi
