#include "store/object_store.hpp"

#include <cpl_error.h>
#include <cpl_string.h>
#include <cpl_vsi.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <memory>

#include "common/atomic_file.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"

namespace rv::store {
namespace {

// The storage's own words for the last failure (GDAL's error, e.g. the S3 server's message).
std::string last_error(const std::string& what) {
  const char* msg = CPLGetLastErrorMsg();
  std::string why = msg && *msg ? msg : "unknown error";
  return valid_utf8(what + ": " + why);
}

struct VsiClose {
  void operator()(VSILFILE* f) const {
    if (f) VSIFCloseL(f);
  }
};
using VsiFile = std::unique_ptr<VSILFILE, VsiClose>;

// GDAL caches what it learnt of /vsis3/ paths (sizes, listings). Other daemons write the same
// bucket, and a recursive removal leaves listings behind: what is asked is asked afresh.
void forget_cached(const std::string& vsi_path, bool remote) {
  if (remote) VSICurlPartialClearCache(vsi_path.c_str());
}

// GDAL's default handler prints warnings (an HTTP failure, a retry) on stderr, where the daemon
// writes its JSON log: the storage's questions keep them quiet, and its failures carry the message
// (CPLGetLastErrorMsg is kept whatever the handler). The handler stack is per thread.
struct QuietErrors {
  QuietErrors() { CPLPushErrorHandler(CPLQuietErrorHandler); }
  ~QuietErrors() { CPLPopErrorHandler(); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;
};

void check_key(std::string_view key) {
  if (!is_object_key(key))
    throw Error(ErrorKind::internal, "not an object key: '" + std::string(key.substr(0, 80)) + "'");
}

// Writes `bytes` sequentially to the VSI path `path`; checks the close, where an upload ends.
void write_object(const std::string& path, const char* data, size_t size, const std::string& what) {
  CPLErrorReset();
  VSILFILE* f = VSIFOpenL(path.c_str(), "wb");
  if (!f) throw Error(ErrorKind::io, last_error("cannot write " + what));
  const size_t written = size ? VSIFWriteL(data, 1, size, f) : 0;
  const int closed = VSIFCloseL(f);
  if (written != size || closed != 0) throw Error(ErrorKind::io, last_error("cannot write " + what));
}

std::chrono::system_clock::time_point from_seconds(int64_t s, int64_t ns = 0) {
  return std::chrono::system_clock::time_point(std::chrono::duration_cast<std::chrono::system_clock::duration>(
      std::chrono::seconds(s) + std::chrono::nanoseconds(ns)));
}

class LocalReader final : public ObjectReader {
 public:
  LocalReader(int fd, const struct stat& st)
      : fd_(fd),
        size_(static_cast<uint64_t>(st.st_size)),
        modified_(from_seconds(st.st_mtim.tv_sec, st.st_mtim.tv_nsec)) {}
  ~LocalReader() override { ::close(fd_); }
  uint64_t size() const override { return size_; }
  std::chrono::system_clock::time_point modified() const override { return modified_; }
  int64_t read_at(char* into, size_t n, uint64_t offset) override {
    const ssize_t got = ::pread(fd_, into, n, static_cast<off_t>(offset));
    return got < 0 ? -1 : got;
  }

 private:
  int fd_;
  uint64_t size_;
  std::chrono::system_clock::time_point modified_;
};

// An object read through GDAL's VSI: on a bucket, ranged GETs. A response asks 64 KiB at a time;
// each read of GDAL's handle past what it holds is a request to the server, so the reader asks
// for kReadAhead bytes at once and serves the next reads from them (an 86 MB COG in 21 requests,
// not 1300).
class VsiReader final : public ObjectReader {
 public:
  static constexpr size_t kReadAhead = size_t{4} << 20;
  VsiReader(VsiFile f, uint64_t size, std::chrono::system_clock::time_point modified)
      : f_(std::move(f)), size_(size), modified_(modified) {}
  uint64_t size() const override { return size_; }
  std::chrono::system_clock::time_point modified() const override { return modified_; }
  int64_t read_at(char* into, size_t n, uint64_t offset) override {
    const QuietErrors quiet;
    if (offset >= size_) return 0;
    n = static_cast<size_t>(std::min<uint64_t>(n, size_ - offset));
    if (offset < held_at_ || offset + n > held_at_ + held_.size()) {
      const size_t want = static_cast<size_t>(std::min<uint64_t>(std::max(n, kReadAhead), size_ - offset));
      held_.resize(want);
      if (VSIFSeekL(f_.get(), offset, SEEK_SET) != 0) return -1;
      // Short of the known size is a failure (this GDAL has no error flag on a handle).
      if (VSIFReadL(held_.data(), 1, want, f_.get()) != want) {
        held_.clear();
        return -1;
      }
      held_at_ = offset;
    }
    std::memcpy(into, held_.data() + (offset - held_at_), n);
    return static_cast<int64_t>(n);
  }

 private:
  VsiFile f_;
  uint64_t size_;
  std::chrono::system_clock::time_point modified_;
  std::vector<char> held_;  // bytes [held_at_, held_at_ + held_.size()) of the object
  uint64_t held_at_ = 0;
};

}  // namespace

std::unique_ptr<ObjectReader> open_local_file(const std::string& path) {
  const int fd = open_regular_file(path);
  if (fd < 0) return nullptr;
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    ::close(fd);
    throw Error(ErrorKind::io, "cannot stat a result file");
  }
  return std::make_unique<LocalReader>(fd, st);
}

bool is_object_key(std::string_view key) {
  if (key.empty() || key.front() == '/' || key.back() == '/' || key.size() > 512) return false;
  if (key.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-/") !=
      std::string_view::npos)
    return false;
  size_t at = 0;
  while (at <= key.size()) {
    size_t end = key.find('/', at);
    if (end == std::string_view::npos) end = key.size();
    const std::string_view part = key.substr(at, end - at);
    if (part.empty() || part == "." || part == "..") return false;
    at = end + 1;
  }
  return true;
}

ObjectStore::ObjectStore(const std::string& location) : location_(location) {
  if (location.rfind("s3://", 0) == 0) {
    std::string rest = location.substr(5);
    while (!rest.empty() && rest.back() == '/') rest.pop_back();
    const std::string bucket = rest.substr(0, rest.find('/'));
    if (bucket.empty() || (rest.size() > bucket.size() && !is_object_key(rest.substr(bucket.size() + 1))) ||
        bucket.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789.-") != std::string::npos)
      throw Error(ErrorKind::invalid_argument, "results: '" + location.substr(0, 200) +
                                                   "' is no s3://bucket/prefix (a bucket name, then a prefix of "
                                                   "letters, digits and . _ - /)");
    root_ = "/vsis3/" + rest;
    remote_ = true;
  } else {
    if (location.empty()) throw Error(ErrorKind::invalid_argument, "results: an empty location");
    root_ = std::filesystem::absolute(location).lexically_normal().string();
    while (root_.size() > 1 && root_.back() == '/') root_.pop_back();
  }
}

std::string ObjectStore::path(std::string_view key) const {
  check_key(key);
  return root_ + "/" + std::string(key);
}

std::string ObjectStore::without_paths(std::string message) const {
  const std::string root = root_ + "/";
  for (size_t at; (at = message.find(root)) != std::string::npos;) message.erase(at, root.size());
  return message;
}

void ObjectStore::put(std::string_view key, std::string_view bytes) const {
  const QuietErrors quiet;
  const std::string p = path(key);
  if (!remote_) {
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(p).parent_path(), ec);
    write_file_atomically(p, bytes);
    return;
  }
  write_object(p, bytes.data(), bytes.size(), std::string(key));
}

void ObjectStore::put_file(std::string_view key, const std::filesystem::path& local,
                           const std::atomic<bool>* cancel) const {
  const QuietErrors quiet;
  auto stop = [&] {
    if (cancel && cancel->load())
      throw Error(ErrorKind::cancelled, "the upload of " + std::string(key) + " was cancelled");
  };
  stop();
  std::ifstream in(local, std::ios::binary);
  if (!in) throw Error(ErrorKind::io, "cannot read " + local.filename().string());
  const std::string p = path(key);
  if (!remote_) {
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(p).parent_path(), ec);
    std::filesystem::copy_file(local, p, std::filesystem::copy_options::overwrite_existing, ec);
    if (ec) throw Error(ErrorKind::io, "cannot write " + std::string(key) + ": " + ec.message());
    return;
  }
  // Streamed in blocks: a raster may be larger than memory should hold twice.
  CPLErrorReset();
  VsiFile out(VSIFOpenL(p.c_str(), "wb"));
  if (!out) throw Error(ErrorKind::io, last_error("cannot write " + std::string(key)));
  try {
    std::vector<char> block(size_t{8} << 20);
    while (in) {
      stop();
      in.read(block.data(), static_cast<std::streamsize>(block.size()));
      const size_t n = static_cast<size_t>(in.gcount());
      if (n && VSIFWriteL(block.data(), 1, n, out.get()) != n)
        throw Error(ErrorKind::io, last_error("cannot write " + std::string(key)));
    }
  } catch (...) {
    // A /vsis3/ handle cannot be abandoned: closing it completes the upload with what it has.
    // That partial object goes at once.
    VSIFCloseL(out.release());
    VSIUnlink(p.c_str());
    throw;
  }
  if (VSIFCloseL(out.release()) != 0) throw Error(ErrorKind::io, last_error("cannot write " + std::string(key)));
}

int ObjectStore::put_tree(std::string_view prefix, const std::filesystem::path& local,
                          const std::atomic<bool>* cancel) const {
  const QuietErrors quiet;
  int count = 0;
  std::error_code ec;
  for (auto it = std::filesystem::recursive_directory_iterator(local, ec);
       !ec && it != std::filesystem::recursive_directory_iterator(); it.increment(ec)) {
    if (!it->is_regular_file()) continue;
    const std::string rel = it->path().lexically_relative(local).generic_string();
    put_file(std::string(prefix) + "/" + rel, it->path(), cancel);
    ++count;
  }
  if (ec) throw Error(ErrorKind::io, "cannot read " + local.filename().string() + ": " + ec.message());
  return count;
}

std::optional<std::string> ObjectStore::get(std::string_view key) const {
  const QuietErrors quiet;
  const std::string p = path(key);
  forget_cached(p, remote_);
  VSIStatBufL st;
  if (VSIStatExL(p.c_str(), &st, VSI_STAT_EXISTS_FLAG | VSI_STAT_NATURE_FLAG | VSI_STAT_SIZE_FLAG) != 0 ||
      VSI_ISDIR(st.st_mode))
    return std::nullopt;
  CPLErrorReset();
  VsiFile f(VSIFOpenL(p.c_str(), "rb"));
  if (!f) throw Error(ErrorKind::io, last_error("cannot read " + std::string(key)));
  std::string out;
  std::vector<char> block(size_t{1} << 20);
  for (;;) {
    const size_t n = VSIFReadL(block.data(), 1, block.size(), f.get());
    out.append(block.data(), n);
    if (n < block.size()) break;
  }
  // A short read is a failure (this GDAL has no error flag on a handle): the size is known.
  if (out.size() != static_cast<size_t>(st.st_size))
    throw Error(ErrorKind::io, last_error("cannot read " + std::string(key) + " whole"));
  return out;
}

int ObjectStore::get_tree(std::string_view prefix, const std::filesystem::path& local) const {
  const QuietErrors quiet;
  int count = 0;
  for (const std::string& name : list(prefix)) {
    const std::string key = std::string(prefix) + "/" + name;
    if (!is_object_key(key)) continue;  // nothing this program wrote
    // Every name the listing gave is copied, or the copy fails: a tree missing one of its files
    // (removed meanwhile, or a request to the storage that failed) must not pass for the whole.
    VSIStatBufL st;
    if (VSIStatL(path(key).c_str(), &st) != 0)
      throw Error(ErrorKind::io, last_error("cannot read " + key + ", listed a moment before"));
    if (VSI_ISDIR(st.st_mode)) {
      count += get_tree(key, local / name);
      continue;
    }
    const auto bytes = get(key);
    if (!bytes) throw Error(ErrorKind::io, "cannot read " + key + ", listed a moment before");
    std::error_code ec;
    std::filesystem::create_directories(local, ec);
    write_file_atomically((local / name).string(), *bytes);
    ++count;
  }
  return count;
}

std::vector<std::string> ObjectStore::list(std::string_view prefix) const {
  const QuietErrors quiet;
  const std::string p = prefix.empty() ? root_ : path(prefix);
  forget_cached(p, remote_);
  // On a bucket, every key below the prefix, cut at its first '/': listings with a delimiter are
  // not answered alike by every S3-compatible server (s3rver leaves out the "folders" of keys two
  // levels down), a flat listing is.
  char** names = remote_ ? VSIReadDirRecursive(p.c_str()) : VSIReadDir(p.c_str());
  std::vector<std::string> out;
  for (char** n = names; n && *n; ++n) {
    const std::string_view name(*n);
    const std::string_view first = name.substr(0, name.find('/'));
    if (!first.empty() && first != "." && first != "..") out.emplace_back(first);
  }
  CSLDestroy(names);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

bool ObjectStore::exists(std::string_view key) const {
  const QuietErrors quiet;
  const std::string p = path(key);
  forget_cached(p, remote_);
  VSIStatBufL st;
  return VSIStatExL(p.c_str(), &st, VSI_STAT_EXISTS_FLAG) == 0;
}

void ObjectStore::probe() const {
  const QuietErrors quiet;
  if (!remote_) return;
  // The bucket itself: a listing of a prefix with nothing below it, or of a bucket that is not
  // there, answers "nothing" without an error; a bucket that exists answers as a folder.
  const std::string bucket = root_.substr(0, root_.find('/', std::string("/vsis3/").size()));
  forget_cached(bucket, remote_);
  CPLErrorReset();
  VSIStatBufL st;
  if (VSIStatExL(bucket.c_str(), &st, VSI_STAT_EXISTS_FLAG | VSI_STAT_NATURE_FLAG) == 0 && VSI_ISDIR(st.st_mode))
    return;
  const char* why = CPLGetLastErrorMsg();
  throw Error(ErrorKind::busy, valid_utf8("the results storage is unavailable: " + location_ + ": " +
                                          (why && *why ? std::string(why) : "no such bucket, or no access to it")));
}

std::unique_ptr<ObjectReader> ObjectStore::open(std::string_view key) const {
  const QuietErrors quiet;
  const std::string p = path(key);
  if (!remote_) return open_local_file(p);
  forget_cached(p, remote_);
  VSIStatBufL st;
  if (VSIStatExL(p.c_str(), &st, VSI_STAT_EXISTS_FLAG | VSI_STAT_NATURE_FLAG | VSI_STAT_SIZE_FLAG) != 0 ||
      VSI_ISDIR(st.st_mode))
    return nullptr;
  CPLErrorReset();
  VsiFile f(VSIFOpenL(p.c_str(), "rb"));
  if (!f) throw Error(ErrorKind::io, last_error("cannot read " + std::string(key)));
  return std::make_unique<VsiReader>(std::move(f), static_cast<uint64_t>(st.st_size), from_seconds(st.st_mtime));
}

void ObjectStore::copy(std::string_view from, std::string_view to) const {
  const QuietErrors quiet;
  const std::string a = path(from), b = path(to);
  if (!remote_) {
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(b).parent_path(), ec);
    std::filesystem::remove(b, ec);
    std::filesystem::create_hard_link(a, b, ec);
    if (ec) std::filesystem::copy_file(a, b, std::filesystem::copy_options::overwrite_existing, ec);
    if (ec) throw Error(ErrorKind::io, "cannot copy " + std::string(from) + ": " + ec.message());
    return;
  }
  forget_cached(a, remote_);
  CPLErrorReset();
  VsiFile in(VSIFOpenL(a.c_str(), "rb"));
  if (!in) throw Error(ErrorKind::io, last_error("cannot read " + std::string(from)));
  VsiFile out(VSIFOpenL(b.c_str(), "wb"));
  if (!out) throw Error(ErrorKind::io, last_error("cannot write " + std::string(to)));
  std::vector<char> block(size_t{8} << 20);
  for (;;) {
    const size_t n = VSIFReadL(block.data(), 1, block.size(), in.get());
    if (n && VSIFWriteL(block.data(), 1, n, out.get()) != n)
      throw Error(ErrorKind::io, last_error("cannot write " + std::string(to)));
    if (n < block.size()) break;
  }
  if (VSIFCloseL(out.release()) != 0) throw Error(ErrorKind::io, last_error("cannot write " + std::string(to)));
}

std::vector<ListedObject> ObjectStore::list_all(std::string_view prefix) const {
  const QuietErrors quiet;
  const std::string p = prefix.empty() ? root_ : path(prefix);
  std::vector<ListedObject> out;
  if (!remote_) {
    std::error_code ec;
    for (auto it = std::filesystem::recursive_directory_iterator(p, ec);
         !ec && it != std::filesystem::recursive_directory_iterator(); it.increment(ec)) {
      struct stat st {};
      if (::lstat(it->path().c_str(), &st) != 0) continue;  // removed meanwhile
      std::string key = it->path().lexically_relative(p).generic_string();
      if (S_ISDIR(st.st_mode)) {
        if (!std::filesystem::is_empty(it->path(), ec)) continue;
        ec.clear();
        key += "/";
      } else if (!S_ISREG(st.st_mode)) {
        continue;
      }
      out.push_back({std::move(key), from_seconds(st.st_mtim.tv_sec, st.st_mtim.tv_nsec)});
    }
    return out;
  }
  forget_cached(p, remote_);
  CPLErrorReset();
  VSIDIR* dir = VSIOpenDir(p.c_str(), -1, nullptr);
  if (!dir) {
    // A prefix with no object is no error; a storage that cannot be asked is.
    if (CPLGetLastErrorType() == CE_None) return out;
    throw Error(ErrorKind::io, last_error("cannot list " + (prefix.empty() ? location_ : std::string(prefix))));
  }
  while (const VSIDIREntry* e = VSIGetNextDirEntry(dir)) {
    if (VSI_ISDIR(e->nMode)) continue;
    // A time the listing does not give is taken as now: never judged old, never swept. A bucket's
    // listing gives whole seconds, and the object may have been written at any moment of that
    // second: its end is taken, so that no object is judged older than it is.
    out.push_back({e->pszName, e->bMTimeKnown ? from_seconds(e->nMTime + 1) : std::chrono::system_clock::now()});
  }
  VSICloseDir(dir);
  return out;
}

void ObjectStore::remove_tree(std::string_view prefix) const {
  const QuietErrors quiet;
  const std::string p = path(prefix);
  if (!remote_) {
    std::error_code ec;
    std::filesystem::remove_all(p, ec);
    if (ec) throw Error(ErrorKind::io, "cannot remove " + std::string(prefix) + ": " + ec.message());
    return;
  }
  forget_cached(p, remote_);
  VSIStatBufL st;
  if (VSIStatExL(p.c_str(), &st, VSI_STAT_EXISTS_FLAG | VSI_STAT_NATURE_FLAG) != 0) return;
  CPLErrorReset();
  const int rc = VSI_ISDIR(st.st_mode) ? VSIRmdirRecursive(p.c_str()) : VSIUnlink(p.c_str());
  forget_cached(root_, remote_);
  if (rc != 0) throw Error(ErrorKind::io, last_error("cannot remove " + std::string(prefix)));
}

bool ObjectStore::abort_pending_uploads() const {
  const QuietErrors quiet;
  if (!remote_) return false;
  CPLErrorReset();
  return VSIAbortPendingUploads((root_ + "/").c_str()) != 0;
}

}  // namespace rv::store
