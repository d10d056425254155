// Two GeoTIFFs compared as a reader sees them: size, geotransform, CRS, data type, nodata, units,
// block size, band metadata, compression, categories and every cell value. Header-only, for the
// tests that compare a job's files with another run's (streamed against whole, edited against
// fresh).
#pragma once

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <string>

#include <gdal_priv.h>

#include "rv/gdal/raster_io.hpp"

namespace rv::test {

inline std::unique_ptr<GDALDataset> open_raster_file(const std::string& path) {
  return std::unique_ptr<GDALDataset>(GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
}

// Everything a reader of the file sees, compared between two files.
inline void expect_same_geotiff(const std::string& a, const std::string& b) {
  SCOPED_TRACE(a + " vs " + b);
  const auto da = open_raster_file(a), db = open_raster_file(b);
  ASSERT_TRUE(da && db);
  EXPECT_EQ(da->GetRasterXSize(), db->GetRasterXSize());
  EXPECT_EQ(da->GetRasterYSize(), db->GetRasterYSize());
  double ga[6], gb[6];
  ASSERT_EQ(da->GetGeoTransform(ga), CE_None);
  ASSERT_EQ(db->GetGeoTransform(gb), CE_None);
  for (int i = 0; i < 6; ++i) EXPECT_EQ(ga[i], gb[i]) << "geotransform[" << i << "]";
  ASSERT_TRUE(da->GetSpatialRef() && db->GetSpatialRef());
  EXPECT_TRUE(da->GetSpatialRef()->IsSame(db->GetSpatialRef()));
  GDALRasterBand* ba = da->GetRasterBand(1);
  GDALRasterBand* bb = db->GetRasterBand(1);
  EXPECT_EQ(ba->GetRasterDataType(), bb->GetRasterDataType());
  int has_a = 0, has_b = 0;
  EXPECT_EQ(ba->GetNoDataValue(&has_a), bb->GetNoDataValue(&has_b));
  EXPECT_EQ(has_a, has_b);
  EXPECT_STREQ(ba->GetUnitType(), bb->GetUnitType());
  int bxa = 0, bya = 0, bxb = 0, byb = 0;
  ba->GetBlockSize(&bxa, &bya);
  bb->GetBlockSize(&bxb, &byb);
  EXPECT_EQ(bxa, bxb);
  EXPECT_EQ(bya, byb);
  std::map<std::string, std::string> ma, mb;
  for (char** m = ba->GetMetadata(); m && *m; ++m) ma[*m] = "";
  for (char** m = bb->GetMetadata(); m && *m; ++m) mb[*m] = "";
  EXPECT_EQ(ma, mb);
  auto compression = [](GDALDataset& d) {
    const char* c = d.GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE");
    return std::string(c ? c : "");
  };
  EXPECT_EQ(compression(*da), compression(*db));
  EXPECT_EQ(read_category_labels(a), read_category_labels(b));
  if (ba->GetRasterDataType() == GDT_Float32)
    EXPECT_TRUE(read_float32(a).cells() == read_float32(b).cells()) << "distance values differ";
  else
    EXPECT_TRUE(read_int32(a).cells() == read_int32(b).cells()) << "values differ";
}

}  // namespace rv::test
