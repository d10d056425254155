// The situation of the paper's Fig. 2 (Liu et al. 2019): a seed's identity never reaches some
// cells in the horizontal cycle's scan order, so h-scan assigns them to a farther seed; the
// vertical cycle repairs them. Fixture drawn as ASCII art: a letter is a seed at that cell's
// centre, the expected ownership is drawn beside it.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/validate.hpp"

namespace rv {
namespace {

struct ArtFixture {
  GridSpec grid;
  SeedSet seeds;
};

// Letters become point seeds at the cell centre; features are numbered in letter order.
ArtFixture from_art(const std::vector<std::string>& art) {
  ArtFixture f;
  f.grid.xmin = 0;
  f.grid.res = 1;
  f.grid.height = static_cast<int64_t>(art.size());
  f.grid.width = static_cast<int64_t>(art[0].size());
  f.grid.ymax = static_cast<double>(f.grid.height);
  for (char letter = 'A'; letter <= 'Z'; ++letter)
    for (size_t r = 0; r < art.size(); ++r)
      for (size_t c = 0; c < art[r].size(); ++c)
        if (art[r][c] == letter) {
          const int32_t id = f.seeds.add_feature(f.seeds.owner_code(std::string(1, letter)));
          f.seeds.add_point(id, {f.grid.centre_x(static_cast<int64_t>(c)), f.grid.centre_y(static_cast<int64_t>(r))});
        }
  return f;
}

std::vector<std::string> draw(const ArtFixture& f, const NearestField& field) {
  std::vector<std::string> out;
  for (int64_t r = 0; r < f.grid.height; ++r) {
    std::string row;
    for (int64_t c = 0; c < f.grid.width; ++c)
      row += f.seeds.owner_labels()[f.seeds.site_owner(field.site.at(c, r)) - 1][0] - 'A' + 'a';
    out.push_back(row);
  }
  return out;
}

TEST(PaperFigure2, HScanMissesCellsThatHvScanRepairs) {
  const ArtFixture f = from_art({
      "........",
      "........",
      "........",
      "..A.....",
      "........",
      "...C....",
      "........",
      "......B.",
  });
  const std::vector<std::string> exact = {
      "aaaaaaaa", "aaaaaaaa", "aaaaaaac", "aaaaaccb", "aaacccbb", "acccccbb", "cccccbbb", "ccccbbbb",
  };
  // h-scan: A's identity never reaches (7, 1) and (6, 2), to A's upper right (region II).
  const std::vector<std::string> horizontal = {
      "aaaaaaaa", "aaaaaaac", "aaaaaacc", "aaaaaccb", "aaacccbb", "acccccbb", "cccccbbb", "ccccbbbb",
  };
  ComputeOptions o;
  o.threads = 1;
  o.method = Method::brute_force;
  const NearestField brute = compute(f.seeds, f.grid, o);
  EXPECT_EQ(draw(f, brute), exact);
  o.method = Method::h_scan;
  const NearestField h = compute(f.seeds, f.grid, o);
  EXPECT_EQ(draw(f, h), horizontal);
  EXPECT_EQ(compare_fields(f.seeds, h, brute).wrong_cells, 2);
  for (int threads : {1, 3}) {
    o.threads = threads;
    o.method = Method::hv_scan;
    EXPECT_EQ(draw(f, compute(f.seeds, f.grid, o)), exact);
    o.method = Method::exact;
    EXPECT_EQ(draw(f, compute(f.seeds, f.grid, o)), exact);
  }
}

}  // namespace
}  // namespace rv
