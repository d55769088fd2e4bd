#include "server/auth.h"

#include <openssl/crypto.h>
#include <openssl/sha.h>

#include <fstream>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"

namespace weavefit {

TokenSet::Digest TokenSet::Hash(absl::string_view text) {
  Digest digest;
  SHA256(reinterpret_cast<const unsigned char*>(text.data()), text.size(), digest.data());
  return digest;
}

absl::StatusOr<TokenSet> TokenSet::Parse(absl::string_view text) {
  TokenSet set;
  int line_number = 0;
  for (absl::string_view line : absl::StrSplit(text, '\n')) {
    ++line_number;
    line = absl::StripAsciiWhitespace(line);
    if (line.empty() || line.front() == '#') continue;
    for (char c : line) {
      if (absl::ascii_isspace(static_cast<unsigned char>(c))) {
        return absl::InvalidArgumentError(absl::StrCat(
            "token file line ", line_number, ": a token may not contain whitespace"));
      }
    }
    set.digests_.push_back(Hash(line));
  }
  if (set.digests_.empty()) {
    return absl::InvalidArgumentError(
        "the token file holds no token (one per line; '#' starts a comment)");
  }
  return set;
}

absl::StatusOr<TokenSet> TokenSet::FromFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot read token file ", path));
  std::ostringstream text;
  text << in.rdbuf();
  absl::StatusOr<TokenSet> set = Parse(text.str());
  if (!set.ok()) {
    return absl::Status(set.status().code(), absl::StrCat(path, ": ", set.status().message()));
  }
  return set;
}

bool TokenSet::Accepts(absl::string_view token) const {
  const Digest presented = Hash(token);
  int matches = 0;
  // Every digest is compared, whatever the outcome of the others.
  for (const Digest& digest : digests_) {
    matches += CRYPTO_memcmp(presented.data(), digest.data(), digest.size()) == 0;
  }
  return matches > 0;
}

absl::StatusOr<std::unique_ptr<Authenticator>> Authenticator::FromFile(const std::string& path) {
  auto auth = std::make_unique<Authenticator>();
  auth->path_ = path;
  if (absl::Status s = auth->Reload(); !s.ok()) return s;
  return auth;
}

absl::Status Authenticator::Reload() {
  absl::StatusOr<TokenSet> set = TokenSet::FromFile(path_);
  if (!set.ok()) return set.status();
  auto tokens = std::make_shared<const TokenSet>(*std::move(set));
  std::lock_guard<std::mutex> lock(mutex_);
  tokens_ = std::move(tokens);
  return absl::OkStatus();
}

int Authenticator::token_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return tokens_ ? tokens_->size() : 0;
}

absl::Status Authenticator::Check(absl::string_view authorization_header,
                                  bool header_present) const {
  if (!enabled()) return absl::OkStatus();
  if (!header_present) {
    return absl::UnauthenticatedError(
        "no authorization metadata: send 'authorization: Bearer <token>' "
        "(weavefit --token-file or WEAVEFIT_TOKEN)");
  }
  constexpr absl::string_view kScheme = "Bearer ";
  if (authorization_header.size() <= kScheme.size() ||
      !absl::StartsWithIgnoreCase(authorization_header, kScheme)) {
    return absl::UnauthenticatedError("authorization metadata is not 'Bearer <token>'");
  }
  std::shared_ptr<const TokenSet> tokens;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    tokens = tokens_;
  }
  const absl::string_view token =
      absl::StripAsciiWhitespace(authorization_header.substr(kScheme.size()));
  if (!tokens || !tokens->Accepts(token)) {
    return absl::UnauthenticatedError("the bearer token is not accepted");
  }
  return absl::OkStatus();
}

}  // namespace weavefit
