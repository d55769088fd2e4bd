// Bearer-token access control for weavefitd: tokens from a file, checked on
// every WeaveFit call in constant time, reloadable (SIGHUP) without a restart.
#ifndef WEAVEFIT_SERVER_AUTH_H_
#define WEAVEFIT_SERVER_AUTH_H_

#include <array>
#include <memory>
#include <mutex>
#include <string>
#include "absl/strings/string_view.h"
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace weavefit {

// The accepted tokens, kept only as SHA-256 digests: a presented token is
// hashed and compared with every digest by CRYPTO_memcmp, so neither the
// comparison's time nor its early exit tells how much of a token was right or
// how long the tokens are.
class TokenSet {
 public:
  // One token per line; surrounding blanks are trimmed, blank lines and lines
  // starting with '#' are skipped. INVALID_ARGUMENT when the text holds no
  // token (an empty set would lock every client out) or a token has inner
  // whitespace.
  static absl::StatusOr<TokenSet> Parse(absl::string_view text);
  // Parse() over the file's contents; NOT_FOUND when it cannot be read.
  static absl::StatusOr<TokenSet> FromFile(const std::string& path);

  bool Accepts(absl::string_view token) const;
  int size() const { return static_cast<int>(digests_.size()); }

 private:
  using Digest = std::array<unsigned char, 32>;
  static Digest Hash(absl::string_view text);
  std::vector<Digest> digests_;
};

// The token check of one daemon. Without a token file every call is let
// through (loopback use); with one, a call needs the metadata
// "authorization: Bearer <token>" with a token from the file.
class Authenticator {
 public:
  Authenticator() = default;  // no tokens: open
  // Reads the file; the daemon refuses to start when this fails.
  static absl::StatusOr<std::unique_ptr<Authenticator>> FromFile(const std::string& path);

  bool enabled() const { return !path_.empty(); }
  // Reads the file again. On failure the tokens in force stay (a typo in the
  // file must not lock the lab out) and the error is returned for the log.
  absl::Status Reload();
  // How many tokens are in force (0 without a token file).
  int token_count() const;
  // OK, or UNAUTHENTICATED saying what was wrong (missing header, not a
  // bearer token, unknown token) and never echoing what was presented.
  absl::Status Check(absl::string_view authorization_header, bool header_present) const;

 private:
  std::string path_;
  mutable std::mutex mutex_;
  std::shared_ptr<const TokenSet> tokens_;
};

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_AUTH_H_
