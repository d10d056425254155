// Text that comes from seed files (owner values, field and layer names, GDAL's messages) enters
// as valid UTF-8 by the one rule of rv/field/text.hpp, and owners stay distinct by their raw bytes.
// Untrusted GeoPackages whose reading SQLite would compute without bounds are refused.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include <cpl_vsi.h>

#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "vector_test_util.hpp"

namespace rv {
namespace {

using test::ScratchDir;

// A GeoPackage of one point per value, layer `layer`, text field `field` holding the raw bytes.
std::string gpkg(const std::string& path, const std::string& layer, const std::string& field,
                 const std::vector<std::string>& values) {
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GPKG");
  std::unique_ptr<GDALDataset> ds(driver->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
  OGRSpatialReference srs;
  srs.importFromEPSG(32633);
  OGRLayer* l = ds->CreateLayer(layer.c_str(), &srs, wkbPoint, nullptr);
  OGRFieldDefn defn(field.c_str(), OFTString);
  EXPECT_EQ(l->CreateField(&defn), OGRERR_NONE);
  for (size_t i = 0; i < values.size(); ++i) {
    OGRFeature f(l->GetLayerDefn());
    f.SetField(0, values[i].c_str());  // OGR stores the bytes as given
    f.SetGeometryDirectly(new OGRPoint(500000.0 + 1000.0 * static_cast<double>(i), 6000000.0));
    EXPECT_EQ(l->CreateFeature(&f), OGRERR_NONE);
  }
  return path;
}

void exec(const std::string& path, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  char* err = nullptr;
  const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
  EXPECT_EQ(rc, SQLITE_OK) << (err ? err : "");
  sqlite3_free(err);
  sqlite3_close(db);
}

// Copies a file into /vsimem/ (confined reading takes in-memory files only).
std::string to_vsimem(const std::string& path, const std::string& name) {
  const std::string mem = "/vsimem/rv_outside_text/" + name;
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  VSILFILE* f = VSIFOpenL(mem.c_str(), "wb");
  VSIFWriteL(bytes.data(), 1, bytes.size(), f);
  VSIFCloseL(f);
  return mem;
}

Error error_of(const SeedReadOptions& o) {
  try {
    load_seeds(o);
  } catch (const Error& e) {
    return e;
  }
  ADD_FAILURE() << "no error";
  return Error(ErrorKind::internal, "");
}

class OutsideText : public ::testing::Test {
 protected:
  void SetUp() override { gdal_init(); }
  void TearDown() override { VSIRmdirRecursive("/vsimem/rv_outside_text"); }
  ScratchDir dir_;
};

TEST_F(OutsideText, OwnerValuesAreEscapedAndStayDistinctByTheirBytes) {
  SeedReadOptions o;
  o.paths = {gpkg(dir_.file("owners.gpkg"), "seeds", "state", {"A\x80", "A", "A\\x80", "\xc3\x98resund"})};
  o.owner_field = "state";
  const LoadedSeeds l = load_seeds(o);
  // Four raw values, four owners: the byte 0x80 and the typed text "\x80" are told apart.
  EXPECT_EQ(l.seeds.owner_labels(), (std::vector<std::string>{"A\\x80", "A", "A\\\\x80", "\xc3\x98resund"}));
  for (const std::string& label : l.seeds.owner_labels()) EXPECT_TRUE(is_valid_utf8(label)) << label;
}

TEST_F(OutsideText, FieldAndLayerNamesInMessagesAreEscaped) {
  SeedReadOptions o;
  o.paths = {gpkg(dir_.file("names.gpkg"), "se\xff", "o\x80", {"A", "B"})};
  o.owner_field = "nope";
  const Error e = error_of(o);
  EXPECT_EQ(e.kind(), ErrorKind::invalid_argument) << e.what();
  EXPECT_TRUE(is_valid_utf8(e.what())) << e.what();
  EXPECT_NE(std::string(e.what()).find("(fields: o\\x80)"), std::string::npos) << e.what();
  EXPECT_NE(std::string(e.what()).find(":se\\xFF"), std::string::npos) << e.what();
  // Without an owner field the names become the features' sources.
  o.owner_field.reset();
  const LoadedSeeds l = load_seeds(o);
  for (const Feature& f : l.seeds.features()) {
    EXPECT_TRUE(is_valid_utf8(f.source.str())) << f.source;
    EXPECT_NE(f.source.str().find("se\\xFF:fid"), std::string::npos) << f.source;
  }
}

TEST_F(OutsideText, GdalMessagesQuotingBrokenDataAreEscaped) {
  const std::string path = gpkg(dir_.file("schema.gpkg"), "seeds", "state", {"A", "B"});
  // SQLite's parser stops at the bytes and quotes them in its message, which GDAL passes on.
  exec(path,
       "PRAGMA writable_schema=1; UPDATE sqlite_master SET sql = replace(sql, '\"state\" TEXT)', "
       "'\"state\" TEXT) ' || CAST(x'80ff' AS TEXT)) WHERE name = 'seeds'");
  SeedReadOptions o;
  o.paths = {path};
  const Error e = error_of(o);
  EXPECT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
  EXPECT_TRUE(is_valid_utf8(e.what())) << e.what();
  EXPECT_NE(std::string(e.what()).find("\\x80\\xFF"), std::string::npos) << e.what();
}

TEST_F(OutsideText, UntrustedGeoPackagesWithViewsOrGeneratedColumnsAreRefused) {
  const std::string viewed = gpkg(dir_.file("view.gpkg"), "seeds", "state", {"A", "B"});
  exec(viewed,
       "CREATE VIEW endless AS WITH RECURSIVE c(n) AS (SELECT 1 UNION ALL SELECT n + 1 FROM c) SELECT n FROM c");
  const std::string generated = gpkg(dir_.file("generated.gpkg"), "seeds", "state", {"A", "B"});
  exec(generated, "CREATE TABLE big (id INTEGER PRIMARY KEY, blob AS (zeroblob(1000000000)) VIRTUAL)");
  SeedReadOptions o;
  o.confined = true;
  o.paths = {to_vsimem(viewed, "view.gpkg")};
  Error e = error_of(o);
  EXPECT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
  EXPECT_NE(std::string(e.what()).find("the view 'endless'"), std::string::npos) << e.what();
  o.paths = {to_vsimem(generated, "generated.gpkg")};
  e = error_of(o);
  EXPECT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
  EXPECT_NE(std::string(e.what()).find("generated column 'blob'"), std::string::npos) << e.what();
  // A user's own file (not confined) is theirs to read: the plain table loads.
  o.confined = false;
  o.paths = {generated};
  o.layers = {"seeds"};
  EXPECT_EQ(load_seeds(o).seeds.features().size(), 2u);
}

TEST_F(OutsideText, FileNamesThatAreNotUtf8AreShownEscaped) {
  SeedReadOptions o;
  o.paths = {dir_.file("missing\xff.gpkg")};
  const Error e = error_of(o);
  EXPECT_EQ(e.kind(), ErrorKind::not_found) << e.what();
  EXPECT_NE(std::string(e.what()).find("missing\\xFF.gpkg"), std::string::npos) << e.what();
  // Confined, an in-memory file that does not open is a damaged upload, not a missing one.
  o.confined = true;
  o.paths = {"/vsizip//vsimem/rv_outside_text/none.zip"};
  EXPECT_EQ(error_of(o).kind(), ErrorKind::invalid_input);
}

}  // namespace
}  // namespace rv
