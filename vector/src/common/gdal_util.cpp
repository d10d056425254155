#include "common/gdal_util.hpp"

#include <algorithm>
#include <cctype>
#include <mutex>

#include <cpl_conv.h>
#include <cpl_vsi.h>

#include "rv/field/text.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv {

void gdal_init() {
  static std::once_flag once;
  std::call_once(once, [] {
    // Only driver registration: no process-wide option is changed (every CRS this library
    // creates sets its own axis mapping), so embedding applications keep their GDAL settings.
    GDALAllRegister();
  });
}

namespace gdal {

namespace {
constexpr size_t kMaxWarnings = 50;
}

ErrorCapture::ErrorCapture() { CPLPushErrorHandlerEx(&ErrorCapture::handler, this); }

ErrorCapture::~ErrorCapture() { CPLPopErrorHandler(); }

void CPL_STDCALL ErrorCapture::handler(CPLErr cls, CPLErrorNum /*num*/, const char* msg) {
  auto* self = static_cast<ErrorCapture*>(CPLGetErrorHandlerUserData());
  if (self == nullptr) return;
  // GDAL quotes the data it chokes on (schema SQL, field names, mutated bytes): its messages are
  // text from outside, made valid UTF-8 here, where they enter.
  const std::string text = escape_utf8(msg != nullptr ? msg : "");
  if (cls == CE_Failure || cls == CE_Fatal) {
    self->last_error_ = text;
  } else if (cls == CE_Warning) {
    if (self->warnings_.size() < kMaxWarnings)
      self->warnings_.push_back(text);
    else
      ++self->dropped_warnings_;
  }
  // CE_Debug and CE_None are dropped (CPL_DEBUG output stays off stderr as well).
}

std::vector<std::string> ErrorCapture::take_warnings() {
  std::vector<std::string> out = std::move(warnings_);
  if (dropped_warnings_ > 0)
    out.push_back("GDAL: " + std::to_string(dropped_warnings_) + " further warnings not shown");
  warnings_.clear();
  dropped_warnings_ = 0;
  return out;
}

ThreadConfigOption::ThreadConfigOption(const char* key, const char* value) : key_(key) {
  if (const char* old = CPLGetThreadLocalConfigOption(key, nullptr)) {
    previous_ = old;
    had_previous_ = true;
  }
  CPLSetThreadLocalConfigOption(key, value);
}

ThreadConfigOption::~ThreadConfigOption() {
  CPLSetThreadLocalConfigOption(key_.c_str(), had_previous_ ? previous_.c_str() : nullptr);
}

namespace {
// The thread-local options of a ConfinedScope and their values (see gdal_util.hpp for why).
constexpr const char* kConfinedOptions[][2] = {
    // A name no request can have: IsAllowedFilename() compares the whole /vsicurl/ name with it.
    {"CPL_VSIL_CURL_ALLOWED_FILENAME", "/rvoronoi-confined/no-network"},
    {"GDAL_HTTP_PROXY", "127.0.0.1:1"},
    {"CPL_ALLOW_VSISTDIN", "NO"},
    {"OGR_SQLITE_LOAD_EXTENSIONS", ""},
    {"OGR_SQLITE_STATIC_VIRTUAL_OGR", "NO"},
};
}  // namespace

ConfinedScope::ConfinedScope() {
  for (const auto& [key, value] : kConfinedOptions)
    options_.push_back(std::make_unique<ThreadConfigOption>(key, value));
  CPLHTTPPushFetchCallback(&ConfinedScope::refuse, this);
}

ConfinedScope::~ConfinedScope() {
  CPLHTTPPopFetchCallback();
  // The options are restored in reverse order, so that nested settings unwind correctly.
  while (!options_.empty()) options_.pop_back();
}

CPLHTTPResult* ConfinedScope::refuse(const char* url, CSLConstList /*options*/, GDALProgressFunc /*progress*/,
                                     void* /*progress_arg*/, CPLHTTPFetchWriteFunc /*write*/, void* /*write_arg*/,
                                     void* self) {
  static_cast<ConfinedScope*>(self)->refused_urls_.emplace_back(url != nullptr ? url : "");
  // The result is freed by the caller with CPLHTTPDestroyResult, hence CPL allocation.
  auto* result = static_cast<CPLHTTPResult*>(CPLCalloc(1, sizeof(CPLHTTPResult)));
  result->nStatus = 1;
  result->pszErrBuf = CPLStrdup("network access is disabled for uploaded data");
  return result;
}

namespace {
bool starts_with(const std::string& s, const char* prefix) { return s.rfind(prefix, 0) == 0; }

bool ends_with_ci(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  return std::equal(suffix.rbegin(), suffix.rend(), s.rbegin(),
                    [](char a, char b) { return std::tolower(static_cast<unsigned char>(a)) == b; });
}
}  // namespace

std::string open_name(const std::string& path) {
  if (starts_with(path, "/vsi")) return path;
  if (ends_with_ci(path, ".zip")) return "/vsizip/" + path;
  return path;
}

bool path_exists(const std::string& path) {
  VSIStatBufL st;
  return VSIStatL(path.c_str(), &st) == 0;
}

SrsPtr parse_srs(const std::string& definition) {
  SrsPtr srs(new OGRSpatialReference());
  srs->SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  ErrorCapture quiet;
  // The limitations forbid reading files or URLs named in the definition: a CRS option of a
  // request must not make the process open arbitrary paths.
  if (srs->SetFromUserInput(definition.c_str(), OGRSpatialReference::SET_FROM_USER_INPUT_LIMITATIONS) != OGRERR_NONE)
    return nullptr;
  return srs;
}

std::string to_wkt2(const OGRSpatialReference& srs) {
  char* wkt = nullptr;
  const char* const options[] = {"FORMAT=WKT2_2019", nullptr};
  std::string out;
  if (srs.exportToWkt(&wkt, options) == OGRERR_NONE && wkt != nullptr) out = wkt;
  CPLFree(wkt);
  return out;
}

}  // namespace gdal
}  // namespace rv
