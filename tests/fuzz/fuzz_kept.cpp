// Fuzz targets: the decoders of what a run keeps for edits, which an edit reads from a base that
// anyone may have made (a checksum recomputed is no defence). One source, one target per decoder
// (RV_FUZZ_KEPT): seed_archive (seeds.bin), site_codes (site_codes.bin), line_pieces
// (lines_*.bin). Seed corpora: tests/fuzz/corpus/fuzz_kept_<decoder>/, files of real bases
// (tools/make-kept-corpus.sh).
//
// Findings: a crash, a sanitizer report, an exception other than rv::Error(invalid_input), or
// bytes that decode but do not encode back to themselves (the layouts have one encoding each).
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

#include "rv/edit/seed_archive.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"
#include "rv/lines/strip_lines.hpp"

namespace {

void require(bool ok) {
  if (!ok) std::abort();
}

#define RV_STR2(x) #x
#define RV_STR(x) RV_STR2(x)
const std::string_view kDecoder = RV_STR(RV_FUZZ_KEPT);

void seed_archive(std::string_view bytes) {
  const rv::SeedArchive a = rv::decode_seed_archive(bytes);
  require(rv::encode_seed_archive(a.seeds, a.numbering) == bytes);
  // What an edit asks of the set it decoded.
  const rv::SeedSet& s = a.seeds;
  for (size_t f = 0; f < s.features().size(); ++f) {
    (void)s.feature_name(static_cast<int32_t>(f));
    require(s.features()[f].owner >= 1 && static_cast<size_t>(s.features()[f].owner) <= s.owner_labels().size());
  }
  for (const rv::Site& site : s.sites())
    require(site.feature >= 0 && static_cast<size_t>(site.feature) < s.features().size());
  for (const int64_t n : a.numbering) require(n >= 1 && n <= rv::kMaxFeatureCode);
}

// The first 4 bytes: the number of sites the codes must fit; the rest: the codes.
void site_codes(std::string_view bytes) {
  if (bytes.size() < 4) return;
  uint32_t sites = 0;
  std::memcpy(&sites, bytes.data(), 4);
  sites %= 1u << 16;
  const std::string_view codes = bytes.substr(4);
  const std::vector<int32_t> table = rv::decode_site_codes(codes, codes.size() / 4, static_cast<int32_t>(sites));
  require(table.size() == codes.size() / 4 + 1 && table[0] == rv::kNoSite);
  std::vector<bool> seen(sites, false);
  for (size_t k = 1; k < table.size(); ++k) {
    if (table[k] == rv::kNoSite) continue;
    require(table[k] >= 0 && static_cast<uint32_t>(table[k]) < sites && !seen[static_cast<size_t>(table[k])]);
    seen[static_cast<size_t>(table[k])] = true;
  }
  require(rv::encode_site_codes(table) == codes);
}

void line_pieces(std::string_view bytes) {
  const rv::LinePieces p = rv::LinePieces::decode(bytes);
  require(p.encode() == bytes);
  // An edit's question of them: the rows naming a dropped site, for maps that keep every site,
  // drop every other one, or are shorter than the sites the pieces name.
  for (const size_t n : {size_t{0}, size_t{1}, size_t{64}, size_t{4096}}) {
    std::vector<int32_t> map(n);
    for (size_t i = 0; i < n; ++i) map[i] = i % 2 == 0 ? static_cast<int32_t>(i) : rv::kNoSite;
    const std::vector<int64_t> rows = p.rows_naming_dropped(map);
    for (size_t i = 1; i < rows.size(); ++i) require(rows[i - 1] < rows[i]);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > (1u << 20)) return 0;
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  try {
    if (kDecoder == "seed_archive") seed_archive(bytes);
    if (kDecoder == "site_codes") site_codes(bytes);
    if (kDecoder == "line_pieces") line_pieces(bytes);
  } catch (const rv::Error& e) {
    require(e.kind() == rv::ErrorKind::invalid_input);
  }
  return 0;
}
