// Where the tests find their data: the repository's fixtures/ (RV_SOURCE_DIR, set by
// rv_add_test) and the shared real-coastline fixtures beside the repository (RV_SHARED_DIR:
// ../shared/fixtures, the Øresund and the western Baltic). Header-only, for every test folder.
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

namespace rv::test {

// The repository's top folder.
inline std::filesystem::path source_dir() {
  const char* env = std::getenv("RV_SOURCE_DIR");
  if (env != nullptr && *env != '\0') return env;
  return std::filesystem::path(__FILE__).parent_path().parent_path().parent_path();
}

// A file of the repository's fixtures/.
inline std::string fixture(const std::string& name) { return (source_dir() / "fixtures" / name).string(); }

// A file of the shared fixtures, or "" when they are not there (the test then says so and skips).
inline std::string shared_fixture(const std::string& name) {
  const char* env = std::getenv("RV_SHARED_DIR");
  const std::filesystem::path dir =
      env != nullptr && *env != '\0' ? std::filesystem::path(env) : source_dir().parent_path() / "shared";
  const std::filesystem::path path = dir / "fixtures" / name;
  return std::filesystem::exists(path) ? path.string() : std::string();
}

}  // namespace rv::test
