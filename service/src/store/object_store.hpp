// Where a shared store keeps the jobs' stored requests, results and edit bases (issue 55): a
// folder every daemon mounts, or an S3-compatible bucket through GDAL's /vsis3/, configured by
// GDAL's standard settings (environment or GDAL config options): AWS_S3_ENDPOINT, AWS_HTTPS,
// AWS_VIRTUAL_HOSTING (FALSE for path-style addressing), AWS_REGION, and the keys from
// AWS_ACCESS_KEY_ID / AWS_SECRET_ACCESS_KEY or a credentials file (AWS_CONFIG_FILE,
// CPL_AWS_CREDENTIALS_FILE).
//
// Keys are '/'-separated relative paths below the location ("<job>/<attempt>/ownership.tif"),
// of letters, digits, '.', '_', '-' and '/', never "..": checked, since they name files.
// Writing: an object is written in one sequential upload (a /vsis3/ write cannot seek), so
// callers write to a local scratch file first and put it; a local file is written under a
// temporary name and renamed. Errors: rv::Error(io), with the storage's own message.
// Thread safety: every member may be called from any thread (GDAL's VSI handlers are).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rv::store {

// An object (or a local file) open for reading by byte range: what an HTTP response streams.
// Not thread safe: one reader serves one response, from one thread at a time.
class ObjectReader {
 public:
  virtual ~ObjectReader() = default;
  virtual uint64_t size() const = 0;
  virtual std::chrono::system_clock::time_point modified() const = 0;
  // Reads up to `n` bytes at `offset` into `into`; returns how many (0 past the end), or -1 when
  // the storage failed (the caller ends the response rather than send garbage).
  virtual int64_t read_at(char* into, size_t n, uint64_t offset) = 0;
};

// Opens a local regular file (never a link's target's FIFO or a directory: open_regular_file);
// nullptr when there is none.
std::unique_ptr<ObjectReader> open_local_file(const std::string& path);

// One object of a listing: its key below the listed prefix, and when it was last written (never
// earlier than it was: a bucket's time to the second is taken at the end of that second).
struct ListedObject {
  std::string key;
  std::chrono::system_clock::time_point modified;
};

class ObjectStore {
 public:
  // `location`: a folder, or "s3://bucket[/prefix]". Throws rv::Error(invalid_argument) for a
  // malformed one.
  explicit ObjectStore(const std::string& location);

  bool remote() const { return remote_; }
  const std::string& location() const { return location_; }
  // The path GDAL's VSI functions open for `key` (a /vsis3/ path, or a local one).
  std::string path(std::string_view key) const;
  // `message` without the location's paths (a storage's message names them; a client knows the
  // objects by key).
  std::string without_paths(std::string message) const;
  // Writes `bytes` as `key`.
  void put(std::string_view key, std::string_view bytes) const;
  // Copies the local file `local` to `key`. `cancel`, when given and set meanwhile, stops the copy
  // between blocks with rv::Error(cancelled); a copy that fails or is cancelled leaves no object.
  void put_file(std::string_view key, const std::filesystem::path& local,
                const std::atomic<bool>* cancel = nullptr) const;
  // Copies every regular file below the local folder `local` to keys below `prefix`, keeping
  // their relative paths; returns how many. `cancel` as for put_file (the files already copied
  // stay: remove_tree them).
  int put_tree(std::string_view prefix, const std::filesystem::path& local,
               const std::atomic<bool>* cancel = nullptr) const;
  // The object's bytes; nullopt when there is none. Throws rv::Error(io) for any other failure.
  std::optional<std::string> get(std::string_view key) const;
  // Copies every object below `prefix` into the local folder `local`, keeping relative paths;
  // returns how many. Throws rv::Error(io) when an object the listing names cannot be read (a
  // tree is copied whole or not at all; what was copied before stays in `local`).
  int get_tree(std::string_view prefix, const std::filesystem::path& local) const;
  // The names directly below `prefix` ("" = the location itself), objects and "folders", sorted;
  // none when it is missing. On a bucket it reads every key below `prefix` (a flat listing).
  std::vector<std::string> list(std::string_view prefix) const;
  bool exists(std::string_view key) const;
  // Asks the storage whether its bucket is there: throws rv::Error(busy), with the storage's
  // message, when it cannot be reached or has no such bucket; a daemon checks before it starts.
  void probe() const;
  // Opens `key` for reading by range; nullptr when there is no such object. Throws rv::Error(io)
  // when the storage cannot be asked.
  std::unique_ptr<ObjectReader> open(std::string_view key) const;
  // Copies the object `from` to `to` (a local folder links it when it can), streamed in blocks.
  void copy(std::string_view from, std::string_view to) const;
  // Every object below `prefix` ("" = everything), with its relative key and time, in one flat
  // listing; on a local folder its empty folders too (as keys ending in '/'), so that a sweep can
  // judge them.
  std::vector<ListedObject> list_all(std::string_view prefix) const;
  // Removes `prefix` and everything below it; nothing there is no error.
  void remove_tree(std::string_view prefix) const;
  // Aborts the multipart uploads left open below the location (a daemon that died mid-upload),
  // where the server allows listing them; false when it does not (or for a local folder).
  bool abort_pending_uploads() const;

 private:
  std::string location_;  // as configured
  std::string root_;      // the VSI path of the location, without a trailing '/'
  bool remote_ = false;
};

// Whether `key` is a key ObjectStore accepts (see the header's comment).
bool is_object_key(std::string_view key);

}  // namespace rv::store
