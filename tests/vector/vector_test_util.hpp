// Helpers for the vector tests: fixture paths, scratch directories, error expectations.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <string>

#include "fixtures.hpp"
#include "rv/field/error.hpp"
#include "rv/field/grid.hpp"
#include "rv/field/seeds.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv::test {

// A w x h grid of `res` metres in UTM zone `zone` N (WGS 84), its north-west corner at (xmin, ymax).
inline GridSpec utm_grid(int64_t w, int64_t h, double res = 200.0, int zone = 33, double xmin = 300000.0,
                         double ymax = 6250000.0) {
  return GridSpec{.xmin = xmin,
                  .ymax = ymax,
                  .res = res,
                  .width = w,
                  .height = h,
                  .crs = describe_crs("EPSG:326" + std::to_string(zone)).wkt};
}

// A fresh directory under the system temp dir, removed with everything in it on destruction.
class ScratchDir {
 public:
  ScratchDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "rv_vector_test_XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string write(const std::string& name, const std::string& content) const {
    std::ofstream(path_ / name) << content;
    return file(name);
  }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

// Runs f, expects rv::Error of `kind` whose message contains every one of `parts`; returns the
// message (empty if nothing was thrown).
inline std::string expect_error(ErrorKind kind, const std::function<void()>& f,
                                std::initializer_list<std::string> parts = {}) {
  try {
    f();
  } catch (const Error& e) {
    EXPECT_EQ(to_string(e.kind()), to_string(kind)) << e.what();
    for (const std::string& p : parts)
      EXPECT_NE(std::string(e.what()).find(p), std::string::npos) << "'" << p << "' not in: " << e.what();
    return e.what();
  }
  ADD_FAILURE() << "no rv::Error(" << to_string(kind) << ") thrown";
  return {};
}

// The geometry and owners of two seed sets, without the sources (which name the files).
inline void expect_same_seeds(const SeedSet& a, const SeedSet& b, const std::string& what) {
  ASSERT_EQ(a.owner_labels(), b.owner_labels()) << what;
  ASSERT_EQ(a.features().size(), b.features().size()) << what;
  for (size_t i = 0; i < a.features().size(); ++i) {
    EXPECT_EQ(a.features()[i].owner, b.features()[i].owner) << what << " feature " << i;
    EXPECT_EQ(a.features()[i].kind, b.features()[i].kind) << what << " feature " << i;
  }
  ASSERT_EQ(a.sites().size(), b.sites().size()) << what;
  for (size_t i = 0; i < a.sites().size(); ++i) {
    const Site& s = a.sites()[i];
    const Site& t = b.sites()[i];
    EXPECT_TRUE(s.a == t.a && s.b == t.b && s.feature == t.feature && s.kind == t.kind)
        << what << " site " << i << ": (" << s.a.x << ", " << s.a.y << ")-(" << s.b.x << ", " << s.b.y << ") vs ("
        << t.a.x << ", " << t.a.y << ")-(" << t.b.x << ", " << t.b.y << ")";
  }
  ASSERT_EQ(a.polygons().size(), b.polygons().size()) << what;
  for (size_t i = 0; i < a.polygons().size(); ++i) {
    EXPECT_EQ(a.polygons()[i].feature, b.polygons()[i].feature) << what;
    EXPECT_EQ(a.polygons()[i].area_site, b.polygons()[i].area_site) << what;
    EXPECT_EQ(a.polygons()[i].rings, b.polygons()[i].rings) << what << " polygon " << i;
  }
}

}  // namespace rv::test
