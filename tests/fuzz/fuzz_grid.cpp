// Fuzz target: the grid arguments as the CLI reads them and as run_job turns them into a grid.
//
// Input: whitespace-separated tokens, like a shell splits the command line:
//   XMIN YMIN XMAX YMAX RES [MARGIN [X Y]...]
// Each token goes through the CLI's reading of an --extent coordinate (rv/options.hpp).
// With the numbers: make_grid (--extent), make_aligned_grid, and plan_grid both with the extent
// and with an extent derived from point seeds (the X Y pairs) grown by MARGIN.
// Findings: a crash, a sanitizer report, an exception other than rv::Error, an rv::Error of an
// unexpected kind, or a grid violating the contract of rv/field/grid.hpp (checked below).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "rv/field/error.hpp"
#include "rv/field/grid.hpp"
#include "rv/job.hpp"
#include "rv/options.hpp"

namespace {

void require(bool ok) {
  if (!ok) std::abort();
}

// The contract of a grid returned by make_grid / make_aligned_grid / plan_grid.
void check_grid(const rv::GridSpec& g) {
  require(g.width >= 1 && g.height >= 1);
  require(g.width <= int64_t{1} << 31 && g.height <= int64_t{1} << 31);
  require(g.cell_count() == g.width * g.height);
  require(std::isfinite(g.xmin) && std::isfinite(g.ymax) && std::isfinite(g.res) && g.res > 0.0);
}

// Errors a caller may see for bad numbers: a malformed or out-of-range value, or a grid too big.
void check_error(const rv::Error& e) {
  require(e.kind() == rv::ErrorKind::invalid_argument || e.kind() == rv::ErrorKind::too_large ||
          e.kind() == rv::ErrorKind::invalid_input);
}

template <class F>
void guarded(F&& f) {
  try {
    f();
  } catch (const rv::Error& e) {
    check_error(e);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 4096) return 0;
  std::vector<std::string> tokens;
  std::string cur;
  for (size_t i = 0; i < size; ++i) {
    const char c = static_cast<char>(data[i]);
    if (c == ' ' || c == '\n' || c == '\t') {
      if (!cur.empty()) tokens.push_back(cur);
      cur.clear();
    } else {
      cur.push_back(c);
    }
  }
  if (!cur.empty()) tokens.push_back(cur);

  std::vector<double> v;
  for (size_t i = 0; i < tokens.size() && i < 64; ++i) {
    try {
      const std::vector<std::string> words(4, tokens[i]);
      const double d = rv::parse_cli_value(*rv::find_flag("extent"), words).box[0];
      require(std::isfinite(d));
      v.push_back(d);
    } catch (const rv::Error& e) {
      require(e.kind() == rv::ErrorKind::invalid_argument);
    }
  }
  if (v.size() < 5) return 0;

  guarded([&] {
    const rv::GridSpec g = rv::make_grid(v[0], v[1], v[2], v[3], v[4], "");
    check_grid(g);
    // Kept at its north-west corner; covers the extent up to rounding noise.
    require(g.xmin == v[0] && g.ymax == v[3]);
  });
  guarded([&] { check_grid(rv::make_aligned_grid(v[0], v[1], v[2], v[3], v[4], "")); });

  rv::LoadedSeeds loaded;
  for (size_t i = 6; i + 1 < v.size(); i += 2) {
    const int32_t f = loaded.seeds.add_feature(loaded.seeds.owner_code(std::to_string(i)));
    loaded.seeds.add_point(f, {v[i], v[i + 1]});
  }
  rv::GridRequest request;
  request.resolution = v[4];
  request.extent = std::array<double, 4>{v[0], v[1], v[2], v[3]};
  guarded([&] { check_grid(rv::plan_grid(request, loaded)); });
  if (!loaded.seeds.features().empty()) {
    request.extent.reset();
    if (v.size() > 5) request.margin = v[5];
    guarded([&] { check_grid(rv::plan_grid(request, loaded)); });
  }
  return 0;
}
