// Confined seed reading (SeedReadOptions::confined): uploaded data that tries to make the process
// read a local file or fetch a URL is refused, and nothing is read or fetched. Every attack is
// also run unconfined once (the CLI's mode) as a control, which proves that the observers below
// do see the access the attack aims at, so the confined "nothing happened" assertions mean
// something.
//
// Observers: a loopback HTTP listener on an ephemeral port that records request lines, and an
// inotify watch on a "secret" local GeoJSON file that records every open of it.
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sqlite3.h>
#include <sys/inotify.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <cpl_conv.h>
#include <cpl_vsi.h>
#include <gdal_priv.h>
#include <ogrsf_frmts.h>

#include "rv/field/error.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace fs = std::filesystem;

#include "fixtures.hpp"

namespace rv {
namespace {

std::string source_dir() { return rv::test::source_dir().string(); }

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// An HTTP "server" on 127.0.0.1:<ephemeral> that records the first line of every request and
// answers 404.
class LoopbackListener {
 public:
  LoopbackListener() {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    addr.sin_port = 0;
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 || ::listen(fd_, 16) != 0)
      throw std::runtime_error("cannot listen on loopback");
    socklen_t len = sizeof addr;
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
    thread_ = std::thread([this] { serve(); });
  }
  ~LoopbackListener() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
  }
  std::string url(const std::string& path) const { return "http://127.0.0.1:" + std::to_string(port_) + path; }
  std::vector<std::string> requests() const {
    std::lock_guard lock(mutex_);
    return requests_;
  }
  // Waits a little for requests that may still be in flight (a control expects one).
  std::vector<std::string> requests_after_settling() const {
    for (int i = 0; i < 20 && requests().empty(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    return requests();
  }

 private:
  void serve() {
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      const int client = ::accept(fd_, nullptr, nullptr);
      if (client < 0) continue;
      std::string data;
      char buf[2048];
      pollfd c{client, POLLIN, 0};
      while (data.find("\r\n\r\n") == std::string::npos && ::poll(&c, 1, 500) > 0) {
        const ssize_t n = ::recv(client, buf, sizeof buf, 0);
        if (n <= 0) break;
        data.append(buf, static_cast<size_t>(n));
      }
      {
        std::lock_guard lock(mutex_);
        requests_.push_back(data.substr(0, data.find("\r\n")));
      }
      const char reply[] = "HTTP/1.0 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
      ::send(client, reply, sizeof reply - 1, MSG_NOSIGNAL);
      ::close(client);
    }
  }

  int fd_ = -1;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  mutable std::mutex mutex_;
  std::vector<std::string> requests_;
};

// Counts opens of one file through inotify.
class OpenWatch {
 public:
  explicit OpenWatch(const std::string& path) {
    fd_ = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (fd_ < 0 || ::inotify_add_watch(fd_, path.c_str(), IN_OPEN | IN_ACCESS) < 0)
      throw std::runtime_error("inotify unavailable");
  }
  ~OpenWatch() { ::close(fd_); }
  // Events since the last call.
  int events() {
    int count = 0;
    alignas(inotify_event) char buf[4096];
    for (ssize_t n; (n = ::read(fd_, buf, sizeof buf)) > 0;)
      for (char* p = buf; p < buf + n; p += sizeof(inotify_event) + reinterpret_cast<inotify_event*>(p)->len) ++count;
    return count;
  }

 private:
  int fd_ = -1;
};

class Confinement : public ::testing::Test {
 protected:
  void SetUp() override {
    gdal_init();
    // The unconfined controls must reach the loopback listener directly, whatever proxy the
    // machine running the tests is configured with.
    for (const char* v : {"http_proxy", "https_proxy", "all_proxy", "HTTP_PROXY", "HTTPS_PROXY", "ALL_PROXY"})
      ::unsetenv(v);
    dir_ = fs::temp_directory_path() / ("rv_confine_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    secret_ = (dir_ / "secret.geojson").string();
    std::ofstream(secret_) << R"({"type":"FeatureCollection","features":[{"type":"Feature","properties":{},)"
                              R"("geometry":{"type":"Point","coordinates":[5,6]}}]})";
    watch_ = std::make_unique<OpenWatch>(secret_);
  }
  void TearDown() override {
    for (const std::string& f : mem_files_) VSIUnlink(f.c_str());
    watch_.reset();
    fs::remove_all(dir_);
  }

  // Puts `bytes` into /vsimem/ as an upload would be, returning its name.
  std::string upload(const std::string& name, const std::string& bytes) {
    const std::string path = "/vsimem/rv_confinement_test/" + name;
    VSILFILE* f = VSIFOpenL(path.c_str(), "wb");
    VSIFWriteL(bytes.data(), 1, bytes.size(), f);
    VSIFCloseL(f);
    mem_files_.push_back(path);
    return path;
  }

  static SeedReadOptions confined(const std::string& path) {
    SeedReadOptions o;
    o.paths = {path};
    o.confined = true;
    return o;
  }

  // Expects rv::Error of `kind`; returns its message.
  static std::string expect_error(ErrorKind kind, const SeedReadOptions& o) {
    try {
      load_seeds(o);
    } catch (const Error& e) {
      EXPECT_EQ(to_string(e.kind()), to_string(kind)) << e.what();
      return e.what();
    }
    ADD_FAILURE() << "no rv::Error(" << to_string(kind) << ") thrown for " << o.paths.front();
    return {};
  }

  // Runs the unconfined control; GDAL errors are expected and irrelevant, only the access counts.
  static void load_unconfined(const std::string& path) {
    SeedReadOptions o;
    o.paths = {path};
    try {
      load_seeds(o);
    } catch (const Error&) {
    }
  }

  fs::path dir_;
  std::string secret_;
  std::unique_ptr<OpenWatch> watch_;
  std::vector<std::string> mem_files_;
  LoopbackListener listener_;
};

// An OGR VRT whose one layer is layer `layer` of the datasource `src`.
std::string vrt(const std::string& src, const std::string& layer) {
  return "<OGRVRTDataSource><OGRVRTLayer name=\"evil\"><SrcDataSource>" + src + "</SrcDataSource><SrcLayer>" + layer +
         "</SrcLayer></OGRVRTLayer></OGRVRTDataSource>";
}

TEST_F(Confinement, VrtReadingALocalFileIsRefusedAndTheFileIsNotOpened) {
  const std::string path = upload("evil.vrt", vrt(secret_, "secret"));
  const std::string msg = expect_error(ErrorKind::invalid_input, confined(path));
  EXPECT_NE(msg.find("allowed drivers"), std::string::npos) << msg;
  EXPECT_EQ(watch_->events(), 0) << "the confined load touched the secret file";

  // Control: unconfined, the VRT really does read the file.
  SeedReadOptions open;
  open.paths = {path};
  EXPECT_EQ(load_seeds(open).seeds.features().size(), 1u);
  EXPECT_GT(watch_->events(), 0);

  const std::string passwd = upload("passwd.vrt", vrt("/etc/passwd", "passwd"));
  expect_error(ErrorKind::invalid_input, confined(passwd));
}

TEST_F(Confinement, VrtFetchingAUrlIsRefusedAndNoRequestIsMade) {
  const std::string path = upload("evil_url.vrt", vrt("/vsicurl/" + listener_.url("/seeds.geojson"), "seeds"));
  expect_error(ErrorKind::invalid_input, confined(path));
  EXPECT_TRUE(listener_.requests().empty());

  load_unconfined(path);
  EXPECT_FALSE(listener_.requests_after_settling().empty()) << "control: the VRT should fetch unconfined";
}

TEST_F(Confinement, GeoJsonCrsLinkIsRefusedAndNoRequestIsMade) {
  // GDAL 3.6's GeoJSON driver fetches a "link"/"url" CRS with importFromUrl() and falls back to
  // WGS 84 silently when the fetch fails.
  for (const std::string& crs :
       {R"({"type":"link","properties":{"href":")" + listener_.url("/crs.wkt") + R"(","type":"ogcwkt"}})",
        R"({"type":"url","properties":{"url":")" + listener_.url("/crs") + R"("}})"}) {
    const std::string path = upload("crs.geojson", R"({"type":"FeatureCollection","crs":)" + crs +
                                                       R"(,"features":[{"type":"Feature","properties":{},)"
                                                       R"("geometry":{"type":"Point","coordinates":[1,2]}}]})");
    const std::string msg = expect_error(ErrorKind::invalid_input, confined(path));
    EXPECT_NE(msg.find("network resource"), std::string::npos) << msg;
    EXPECT_TRUE(listener_.requests().empty()) << crs;
  }
  load_unconfined(mem_files_.back());
  EXPECT_FALSE(listener_.requests_after_settling().empty()) << "control: GeoJSON should fetch the CRS unconfined";
}

TEST_F(Confinement, GeoJsonCrsNamingAFileOrUrlReadsNothing) {
  // A "name" CRS goes through SetFromUserInput with GDAL's limitations (no files, no network):
  // the load may succeed or fail, but nothing is opened or fetched.
  for (const std::string& name : {secret_, listener_.url("/crs"), "/vsicurl/" + listener_.url("/crs")}) {
    const std::string path = upload("name.geojson", R"({"type":"FeatureCollection","crs":{"type":"name",)"
                                                    R"("properties":{"name":")" +
                                                        name +
                                                        R"("}},"features":[{"type":"Feature","properties":{},)"
                                                        R"("geometry":{"type":"Point","coordinates":[1,2]}}]})");
    try {
      load_seeds(confined(path));
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::invalid_input) << e.what();
    }
  }
  EXPECT_EQ(watch_->events(), 0);
  EXPECT_TRUE(listener_.requests().empty());
}

TEST_F(Confinement, KmlNetworkLinkIsNotFollowed) {
  // GDAL's "KML" driver (the one allowed; not LIBKML) reads placemarks and ignores NetworkLinks.
  const std::string path = upload(
      "link.kml", R"(<?xml version="1.0" encoding="UTF-8"?><kml xmlns="http://www.opengis.net/kml/2.2"><Document>)"
                  R"(<NetworkLink><Link><href>)" +
                      listener_.url("/more.kml") +
                      R"(</href></Link></NetworkLink>)"
                      R"(<Placemark><name>p</name><Point><coordinates>10,55</coordinates></Point></Placemark>)"
                      R"(</Document></kml>)");
  EXPECT_EQ(load_seeds(confined(path)).seeds.features().size(), 1u);
  EXPECT_TRUE(listener_.requests().empty());
}

// A valid GeoPackage (one point layer) plus a layer that is a VirtualOGR table: on a connection
// where that SQLite module exists, reading the table opens `target` with GDAL. GDAL 3.6 does not
// register the module on GPKG connections (and ConfinedScope sets OGR_SQLITE_STATIC_VIRTUAL_OGR=NO
// besides); the test pins that the table is an error, not a way out.
std::string virtual_ogr_gpkg(const fs::path& dir, const std::string& target) {
  const std::string file = (dir / "evil.gpkg").string();
  fs::remove(file);
  {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GPKG");
    GDALDataset* ds = driver->Create(file.c_str(), 0, 0, 0, GDT_Unknown, nullptr);
    OGRSpatialReference srs;
    srs.importFromEPSG(32633);
    OGRLayer* layer = ds->CreateLayer("pts", &srs, wkbPoint, nullptr);
    OGRFeature feature(layer->GetLayerDefn());
    feature.SetGeometryDirectly(new OGRPoint(1, 2));
    EXPECT_EQ(layer->CreateFeature(&feature), OGRERR_NONE);
    GDALClose(GDALDataset::ToHandle(ds));
  }
  sqlite3* db = nullptr;
  EXPECT_EQ(sqlite3_open(file.c_str(), &db), SQLITE_OK);
  const std::string create = "CREATE VIRTUAL TABLE evil USING VirtualOGR('" + target + "')";
  char* quoted = sqlite3_mprintf("%Q", create.c_str());
  const std::string sql = std::string("PRAGMA writable_schema=ON;") +
                          "INSERT INTO sqlite_master(type,name,tbl_name,rootpage,sql) VALUES('table','evil','evil',0," +
                          quoted +
                          ");"
                          "INSERT INTO gpkg_contents(table_name,data_type,identifier,srs_id) "
                          "VALUES('evil','features','evil',32633);"
                          "INSERT INTO gpkg_geometry_columns VALUES('evil','GEOMETRY','GEOMETRY',32633,0,0);";
  sqlite3_free(quoted);
  char* error = nullptr;
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK) << (error ? error : "");
  sqlite3_free(error);
  sqlite3_close(db);
  return read_file(file);
}

TEST_F(Confinement, GeoPackageVirtualOgrTableIsRefusedAndReadsNothing) {
  for (const std::string& target :
       {secret_, "/vsicurl/" + listener_.url("/seeds.geojson"), std::string("/etc/passwd")}) {
    const std::string path = upload("evil.gpkg", virtual_ogr_gpkg(dir_, target));
    watch_->events();  // building the file above is not an access by the reader
    expect_error(ErrorKind::invalid_input, confined(path));
    EXPECT_EQ(watch_->events(), 0) << target;
    EXPECT_TRUE(listener_.requests().empty()) << target;
  }
}

TEST_F(Confinement, OnlyInMemoryPathsAreAccepted) {
  const std::string fixture = source_dir() + "/fixtures/demo_basepoints.geojson";
  for (const std::string& path :
       {fixture, secret_, std::string("/vsimem/../") + secret_, "/vsizip/" + source_dir() + "/fixtures/coast_shp.zip",
        "/vsicurl/" + listener_.url("/x"), std::string("/vsistdin/"), "/vsisubfile/0_100," + secret_}) {
    expect_error(ErrorKind::invalid_argument, confined(path));
  }
  EXPECT_EQ(watch_->events(), 0);
  EXPECT_TRUE(listener_.requests().empty());
}

TEST_F(Confinement, DriversOutsideTheAllowListAreRefused) {
  SeedReadOptions o = confined(upload("a.vrt", vrt(secret_, "secret")));
  o.allowed_drivers = {"VRT", "SQLite"};
  const std::string msg = expect_error(ErrorKind::invalid_argument, o);
  EXPECT_NE(msg.find("allowed drivers"), std::string::npos) << msg;
}

TEST_F(Confinement, SelfContainedUploadsOfEveryAllowedFormatLoad) {
  struct Case {
    std::string fixture, name;
    size_t features;
  };
  for (const Case& c :
       {Case{"demo_basepoints.geojson", "a.geojson", 0}, Case{"coast.gpkg", "a.gpkg", 6},
        Case{"all_types.fgb", "a.fgb", 8}, Case{"placemarks.kml", "a.kml", 3}, Case{"coast_shp.zip", "a.zip", 6}}) {
    std::string path = upload(c.name, read_file(source_dir() + "/fixtures/" + c.fixture));
    if (c.name == "a.zip") path = "/vsizip/" + path;
    SeedReadOptions o = confined(path);
    o.on_conflict = ConflictPolicy::lower_code;
    LoadedSeeds loaded;
    ASSERT_NO_THROW(loaded = load_seeds(o)) << c.fixture;
    if (c.features > 0) {
      EXPECT_EQ(loaded.seeds.features().size(), c.features) << c.fixture;
    }
    EXPECT_GT(loaded.seeds.features().size(), 0u) << c.fixture;
  }
  EXPECT_TRUE(listener_.requests().empty());
}

TEST_F(Confinement, ThreadLocalSettingsAreRestoredAfterward) {
  const std::string path = upload("ok.geojson", read_file(source_dir() + "/fixtures/demo_basepoints.geojson"));
  CPLSetThreadLocalConfigOption("GDAL_HTTP_PROXY", "example.invalid:3128");
  ASSERT_NO_THROW(load_seeds(confined(path)));
  EXPECT_STREQ(CPLGetThreadLocalConfigOption("GDAL_HTTP_PROXY", nullptr), "example.invalid:3128");
  CPLSetThreadLocalConfigOption("GDAL_HTTP_PROXY", nullptr);
  EXPECT_EQ(CPLGetThreadLocalConfigOption("CPL_VSIL_CURL_ALLOWED_FILENAME", nullptr), nullptr);
  EXPECT_EQ(CPLGetThreadLocalConfigOption("CPL_ALLOW_VSISTDIN", nullptr), nullptr);
  // And a failing confined load restores them too.
  expect_error(ErrorKind::invalid_input, confined(upload("bad.vrt", vrt(secret_, "secret"))));
  EXPECT_EQ(CPLGetThreadLocalConfigOption("GDAL_HTTP_PROXY", nullptr), nullptr);
}

}  // namespace
}  // namespace rv
