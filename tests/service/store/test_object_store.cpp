// The shared store's objects (issue 55) in a local folder and on an S3 server the test starts
// (s3rver, through GDAL's /vsis3/): the same behaviour from both. Bytes and files round trip
// (a file above GDAL's part size goes up in parts), trees go up and come back, listings,
// removal, ranges read back as written (through GDAL and through ObjectReader), copies, timed flat
// listings, keys that could leave the location are refused, and a server that is gone fails with
// its reason.
#include <gtest/gtest.h>

#include <cpl_conv.h>
#include <cpl_vsi.h>

#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <random>
#include <thread>

#include "free_port.hpp"
#include "rv/field/error.hpp"
#include "s3_server.hpp"
#include "store/object_store.hpp"

namespace {

using rv::Error;
using rv::ErrorKind;
using rv::store::ObjectStore;

rv::test::S3Server& s3() {
  static rv::test::S3Server server;
  return server;
}

std::string random_bytes(size_t n, unsigned seed) {
  std::mt19937 gen(seed);
  std::string s(n, '\0');
  for (char& c : s) c = static_cast<char>(gen() & 0xff);
  return s;
}

class Objects : public ::testing::TestWithParam<bool> {
 protected:
  void SetUp() override {
    static int n = 0;
    const std::string name = "t" + std::to_string(++n);
    if (GetParam()) {
      s3().configure_gdal();
      store_ = std::make_unique<ObjectStore>("s3://" + s3().bucket() + "/runs/" + name);
    } else {
      local_ = std::filesystem::temp_directory_path() / ("rv-objects-" + std::to_string(::getpid()) + "-" + name);
      store_ = std::make_unique<ObjectStore>(local_.string());
    }
    scratch_ = std::filesystem::temp_directory_path() / ("rv-scratch-" + std::to_string(::getpid()) + "-" + name);
    std::filesystem::create_directories(scratch_);
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(scratch_, ec);
    if (!local_.empty()) std::filesystem::remove_all(local_, ec);
  }
  std::unique_ptr<ObjectStore> store_;
  std::filesystem::path local_, scratch_;
};

TEST_P(Objects, BytesAndFilesRoundTrip) {
  EXPECT_EQ(store_->remote(), GetParam());
  EXPECT_FALSE(store_->get("job/request.json"));
  EXPECT_FALSE(store_->exists("job/request.json"));
  store_->put("job/request.json", "{\"inputs\": {}}");
  EXPECT_TRUE(store_->exists("job/request.json"));
  EXPECT_EQ(store_->get("job/request.json").value(), "{\"inputs\": {}}");
  store_->put("job/empty", "");
  EXPECT_EQ(store_->get("job/empty").value(), "");

  // Above the part size set here (5 MB, GDAL's least), so that the upload goes in parts.
  CPLSetConfigOption("CPL_VSIS3_CHUNK_SIZE", "5");
  const std::string big = random_bytes(12u << 20, 7);
  std::ofstream(scratch_ / "ownership.tif", std::ios::binary) << big;
  store_->put_file("job/1/ownership.tif", scratch_ / "ownership.tif");
  CPLSetConfigOption("CPL_VSIS3_CHUNK_SIZE", nullptr);
  EXPECT_EQ(store_->get("job/1/ownership.tif").value(), big);
  // Ranges (how a COG is read): bytes at an offset read back as written.
  VSILFILE* f = VSIFOpenL(store_->path("job/1/ownership.tif").c_str(), "rb");
  ASSERT_NE(f, nullptr);
  ASSERT_EQ(VSIFSeekL(f, 9'000'001, SEEK_SET), 0);
  std::string part(1000, '\0');
  EXPECT_EQ(VSIFReadL(part.data(), 1, part.size(), f), part.size());
  VSIFCloseL(f);
  EXPECT_EQ(part, big.substr(9'000'001, 1000));
  // Read as a response streams it, 64 KiB at a time past several read-ahead blocks, then backwards.
  auto reader = store_->open("job/1/ownership.tif");
  ASSERT_TRUE(reader);
  std::string streamed;
  std::vector<char> chunk(64 << 10);
  for (uint64_t at = 0; at < reader->size();) {
    const int64_t got = reader->read_at(chunk.data(), chunk.size(), at);
    ASSERT_GT(got, 0) << "at " << at;
    streamed.append(chunk.data(), static_cast<size_t>(got));
    at += static_cast<uint64_t>(got);
  }
  EXPECT_TRUE(streamed == big) << "the streamed object differs";
  ASSERT_EQ(reader->read_at(chunk.data(), 100, 5'000'000), 100);
  EXPECT_EQ(std::string(chunk.data(), 100), big.substr(5'000'000, 100));

  // A cancelled copy (a dismissal, a shutdown) leaves no object, partial or whole.
  std::atomic<bool> cancel{true};
  try {
    store_->put_file("job/2/ownership.tif", scratch_ / "ownership.tif", &cancel);
    ADD_FAILURE() << "a cancelled upload went on";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::cancelled);
  }
  EXPECT_FALSE(store_->exists("job/2/ownership.tif"));
}

TEST_P(Objects, TreesListAndRemove) {
  std::filesystem::create_directories(scratch_ / "up" / "edit-base");
  std::ofstream(scratch_ / "up" / "report.json") << "{}";
  std::ofstream(scratch_ / "up" / "edit-base" / "manifest.json") << "{\"rasters\": {}}";
  std::ofstream(scratch_ / "up" / "edit-base" / "seeds.bin", std::ios::binary) << random_bytes(4096, 3);
  EXPECT_EQ(store_->put_tree("job/2", scratch_ / "up"), 3);
  EXPECT_EQ(store_->list("job/2"), (std::vector<std::string>{"edit-base", "report.json"}));
  EXPECT_EQ(store_->list("job"), (std::vector<std::string>{"2"}));
  EXPECT_EQ(store_->list(""), (std::vector<std::string>{"job"}));
  EXPECT_EQ(store_->get_tree("job/2", scratch_ / "down"), 3);
  for (const char* name : {"report.json", "edit-base/manifest.json", "edit-base/seeds.bin"}) {
    std::ifstream a(scratch_ / "up" / name, std::ios::binary), b(scratch_ / "down" / name, std::ios::binary);
    EXPECT_EQ(std::string(std::istreambuf_iterator<char>(a), {}), std::string(std::istreambuf_iterator<char>(b), {}))
        << name;
  }
  store_->put("job/3/report.json", "{}");
  store_->remove_tree("job/2");
  EXPECT_FALSE(store_->get("job/2/report.json"));
  EXPECT_TRUE(store_->list("job/2").empty());
  EXPECT_EQ(store_->list("job"), (std::vector<std::string>{"3"}));
  store_->remove_tree("job/2");              // nothing there: no error
  store_->remove_tree("job/3/report.json");  // one object
  EXPECT_FALSE(store_->exists("job/3/report.json"));
}

TEST_P(Objects, ReadersServeRangesCopiesAndTimedListings) {
  const std::string bytes = random_bytes(300'000, 11);
  const auto before = std::chrono::system_clock::now() - std::chrono::seconds(2);
  store_->put("job/1/ownership.tif", bytes);
  // A reader by range, as a response streams it: size, time, bytes at offsets, nothing past the end.
  auto r = store_->open("job/1/ownership.tif");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->size(), bytes.size());
  EXPECT_GE(r->modified(), before - std::chrono::seconds(1));  // S3 times are whole seconds
  std::string part(70'000, '\0');
  EXPECT_EQ(r->read_at(part.data(), part.size(), 200'000), 70'000);
  EXPECT_EQ(part, bytes.substr(200'000, 70'000));
  EXPECT_EQ(r->read_at(part.data(), part.size(), 250'000), 50'000);  // the tail only
  EXPECT_EQ(part.substr(0, 50'000), bytes.substr(250'000));
  EXPECT_EQ(r->read_at(part.data(), part.size(), bytes.size()), 0);
  EXPECT_FALSE(store_->open("job/1/none.tif"));
  EXPECT_FALSE(store_->open("job/1"));  // a "folder" is no object

  // Copies: the bytes, under the new key, the source left as it was.
  store_->copy("job/1/ownership.tif", "job2/base-snapshot/ownership.tif");
  EXPECT_EQ(store_->get("job2/base-snapshot/ownership.tif").value(), bytes);
  EXPECT_EQ(store_->get("job/1/ownership.tif").value(), bytes);

  // One flat listing of everything, with times the sweep judges by: never earlier than the write
  // (a bucket gives whole seconds; the sweep must not take an object for older than it is). The
  // 10 ms allow for the file system's coarser clock.
  const auto written_after = std::chrono::system_clock::now();
  store_->put("job/request.json", "{}");
  std::vector<std::string> keys;
  for (const rv::store::ListedObject& o : store_->list_all("")) {
    keys.push_back(o.key);
    EXPECT_GE(o.modified, before - std::chrono::seconds(1)) << o.key;
    EXPECT_LE(o.modified, std::chrono::system_clock::now() + std::chrono::seconds(2)) << o.key;
    if (o.key == "job/request.json") {
      EXPECT_GE(o.modified, written_after - std::chrono::milliseconds(10));
    }
  }
  std::sort(keys.begin(), keys.end());
  EXPECT_EQ(keys,
            (std::vector<std::string>{"job/1/ownership.tif", "job/request.json", "job2/base-snapshot/ownership.tif"}));
  keys.clear();
  for (const auto& o : store_->list_all("job2")) keys.push_back(o.key);
  EXPECT_EQ(keys, (std::vector<std::string>{"base-snapshot/ownership.tif"}));
  EXPECT_TRUE(store_->list_all("nothing").empty());

  // A storage's message names its own paths; a client knows the keys.
  EXPECT_EQ(store_->without_paths("cannot write " + store_->path("job/1/x.tif") + ": failed"),
            "cannot write job/1/x.tif: failed");
}

TEST(ObjectLocations, ProbesFindTheBucketOrSayWhy) {
  s3().configure_gdal();
  ObjectStore("s3://" + s3().bucket() + "/never/written").probe();  // nothing below it yet: fine
  try {
    ObjectStore("s3://no-such-bucket/jobs").probe();
    ADD_FAILURE() << "a bucket that is not there passed";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::busy);
    EXPECT_NE(std::string(e.what()).find("the results storage is unavailable: s3://no-such-bucket/jobs"),
              std::string::npos)
        << e.what();
  }
  ObjectStore(std::filesystem::temp_directory_path().string()).probe();  // a folder: nothing to ask
}

TEST(ObjectLocations, ATreeWithAnObjectThatCannotBeReadIsNotTakenForTheWhole) {
  // An edit's base is copied from the results as a tree; one of its files gone between the listing
  // and its reading (a dangling link here: listed, unreadable) fails the copy, naming it.
  const auto root = std::filesystem::temp_directory_path() / ("rv-objects-tree-" + std::to_string(::getpid()));
  std::filesystem::remove_all(root);
  std::filesystem::create_directories(root / "job" / "base");
  std::ofstream(root / "job" / "base" / "manifest.json") << "{}";
  std::filesystem::create_symlink(root / "gone.json", root / "job" / "base" / "report.json");
  ObjectStore store(root.string());
  EXPECT_EQ(store.list("job/base"), (std::vector<std::string>{"manifest.json", "report.json"}));
  try {
    store.get_tree("job/base", root / "down");
    ADD_FAILURE() << "a tree missing one of its files was copied";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::io);
    EXPECT_NE(std::string(e.what()).find("job/base/report.json"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(root);
}

TEST(ObjectLocations, EmptyLocalFoldersAreListedForTheSweep) {
  const auto root = std::filesystem::temp_directory_path() / ("rv-objects-empty-" + std::to_string(::getpid()));
  std::filesystem::create_directories(root / "job" / "3");
  ObjectStore store(root.string());
  const auto all = store.list_all("");
  ASSERT_EQ(all.size(), 1u);
  EXPECT_EQ(all[0].key, "job/3/");
  std::filesystem::remove_all(root);
}

TEST_P(Objects, KeysThatCouldLeaveTheLocationAreRefused) {
  for (const char* bad : {"../x", "/etc/passwd", "a//b", "a/./b", "a/../b", "a b", "a\\b", "", "a/"}) {
    EXPECT_FALSE(rv::store::is_object_key(bad)) << bad;
    EXPECT_THROW(store_->put(bad, "x"), Error) << bad;
  }
  EXPECT_TRUE(rv::store::is_object_key("0123abcd/12/ownership.aux.xml"));
}

INSTANTIATE_TEST_SUITE_P(LocalAndS3, Objects, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "S3" : "Local"; });

TEST(ObjectLocations, MalformedOnesAreRefused) {
  for (const char* bad : {"s3://", "s3://Bad_Bucket/x", "s3://b/../x", ""}) {
    try {
      ObjectStore o(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(e.kind(), ErrorKind::invalid_argument) << bad;
    }
  }
}

TEST(ObjectLocations, AServerThatIsGoneFailsWithItsReason) {
  s3().configure_gdal();
  CPLSetConfigOption("AWS_S3_ENDPOINT", ("127.0.0.1:" + std::to_string(rv::test::free_port())).c_str());
  CPLSetConfigOption("GDAL_HTTP_MAX_RETRY", "0");
  ObjectStore gone("s3://rv/x");
  try {
    gone.put("job/request.json", "{}");
    ADD_FAILURE() << "wrote to a server that is not there";
  } catch (const Error& e) {
    EXPECT_EQ(e.kind(), ErrorKind::io);
    EXPECT_NE(std::string(e.what()).find("cannot write job/request.json: "), std::string::npos) << e.what();
  }
  s3().configure_gdal();
  CPLSetConfigOption("GDAL_HTTP_MAX_RETRY", nullptr);
  EXPECT_FALSE(ObjectStore("/tmp").abort_pending_uploads());
}

// A fake S3 endpoint that knows two requests, as GDAL's own tests fake S3: the listing of pending
// multipart uploads (two, one of them under the location) and their abort; it records what it
// was asked. s3rver lists no uploads, so the abort path is tested here.
class FakeUploads {
 public:
  FakeUploads() : port_(rv::test::free_port()) {
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port_));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    int one = 1;
    ::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 || ::listen(fd_, 8) != 0)
      throw std::runtime_error("fake endpoint: cannot listen");
    thread_ = std::thread([this] { serve(); });
  }
  ~FakeUploads() {
    stop_ = true;
    ::shutdown(fd_, SHUT_RDWR);
    ::close(fd_);
    thread_.join();
  }
  int port() const { return port_; }
  std::vector<std::string> requests() {
    std::lock_guard lock(m_);
    return requests_;
  }

 private:
  void serve() {
    while (!stop_) {
      const int c = ::accept(fd_, nullptr, nullptr);
      if (c < 0) return;
      // An idle connection is closed after a moment (the client keeps it for reuse): the server
      // thread must get back to accept() and its stop flag.
      timeval t{0, 200000};
      ::setsockopt(c, SOL_SOCKET, SO_RCVTIMEO, &t, sizeof t);
      for (;;) {  // keep-alive: requests on one connection until it closes
        std::string head;
        char ch;
        while (head.find("\r\n\r\n") == std::string::npos && ::read(c, &ch, 1) == 1) head += ch;
        if (head.empty()) break;
        const std::string line = head.substr(0, head.find("\r\n"));
        {
          std::lock_guard lock(m_);
          requests_.push_back(line);
        }
        std::string body, status = "200 OK";
        if (line.rfind("GET ", 0) == 0 && line.find("uploads") != std::string::npos) {
          body =
              "<?xml version=\"1.0\" encoding=\"UTF-8\"?><ListMultipartUploadsResult><Bucket>rv</Bucket>"
              "<IsTruncated>false</IsTruncated>"
              "<Upload><Key>runs/job1/1/ownership.tif</Key><UploadId>U1</UploadId></Upload>"
              "<Upload><Key>runs/job2/1/distance.tif</Key><UploadId>U2</UploadId></Upload>"
              "</ListMultipartUploadsResult>";
        } else if (line.rfind("DELETE ", 0) == 0) {
          status = "204 No Content";
        } else {
          status = "404 Not Found";
        }
        const std::string answer = "HTTP/1.1 " + status + "\r\nContent-Length: " + std::to_string(body.size()) +
                                   "\r\nContent-Type: application/xml\r\n\r\n" + body;
        if (::write(c, answer.data(), answer.size()) < 0) break;
      }
      ::close(c);
    }
  }
  int port_;
  int fd_ = -1;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::mutex m_;
  std::vector<std::string> requests_;
};

TEST(ObjectLocations, PendingUploadsAreAbortedWhereTheServerListsThem) {
  FakeUploads fake;
  s3().configure_gdal();
  CPLSetConfigOption("AWS_S3_ENDPOINT", ("127.0.0.1:" + std::to_string(fake.port())).c_str());
  EXPECT_TRUE(ObjectStore("s3://rv/runs").abort_pending_uploads());
  s3().configure_gdal();
  const auto asked = fake.requests();
  int aborted = 0;
  for (const std::string& r : asked) {
    if (r.rfind("DELETE ", 0) == 0) {
      ++aborted;
      EXPECT_TRUE(r.find("uploadId=U1") != std::string::npos || r.find("uploadId=U2") != std::string::npos) << r;
    }
  }
  EXPECT_EQ(aborted, 2) << ::testing::PrintToString(asked);
  // s3rver lists no uploads: nothing to abort, said as such.
  EXPECT_FALSE(ObjectStore("s3://" + s3().bucket() + "/runs").abort_pending_uploads());
}

}  // namespace
