#include "server/tls.h"

#include <openssl/err.h>
#include <openssl/pem.h>
#include <openssl/x509.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/common/error.h"
#include "core/common/file_bytes.h"

namespace hgraph::server {
namespace {

struct BioFree {
  void operator()(BIO* b) const { BIO_free(b); }
};
struct X509Free {
  void operator()(X509* x) const { X509_free(x); }
};
struct KeyFree {
  void operator()(EVP_PKEY* k) const { EVP_PKEY_free(k); }
};
using Bio = std::unique_ptr<BIO, BioFree>;
using Cert = std::unique_ptr<X509, X509Free>;
using Key = std::unique_ptr<EVP_PKEY, KeyFree>;

// OpenSSL's reason for the last failure (names no input bytes), and clears its error queue.
std::string OpensslReason() {
  const unsigned long code = ERR_peek_last_error();
  ERR_clear_error();
  if (code == 0) return "no PEM block of that kind";
  const char* reason = ERR_reason_error_string(code);
  return reason ? reason : "unknown OpenSSL error";
}

// Encrypted keys are refused instead of OpenSSL prompting on the terminal for a passphrase.
int NoPassphrase(char*, int, int, void*) { return -1; }

Bio MemoryBio(const std::string& bytes) {
  return Bio(BIO_new_mem_buf(bytes.data(), static_cast<int>(bytes.size())));
}

// Every certificate of a PEM file, at least one.
std::vector<Cert> ReadCertificates(const std::string& pem, const std::string& path,
                                   const char* flag) {
  std::vector<Cert> certs;
  Bio bio = MemoryBio(pem);
  while (X509* x = PEM_read_bio_X509(bio.get(), nullptr, NoPassphrase, nullptr)) {
    certs.emplace_back(x);
  }
  ERR_clear_error();  // the end of the file ends the loop with an error on the queue
  if (certs.empty()) {
    throw InputError(flag, path + " holds no PEM certificate (\"-----BEGIN CERTIFICATE-----\")");
  }
  return certs;
}

void CheckDates(const X509* cert, const std::string& path, const char* flag) {
  if (X509_cmp_current_time(X509_get0_notBefore(cert)) > 0) {
    throw InputError(flag, "the certificate in " + path + " is not valid yet (notBefore)");
  }
  if (X509_cmp_current_time(X509_get0_notAfter(cert)) < 0) {
    throw InputError(flag, "the certificate in " + path + " has expired (notAfter)");
  }
}

}  // namespace

TransportMode TransportModeOf(const TlsFiles& files) {
  if (files.cert.empty() != files.key.empty()) {
    throw InputError(files.cert.empty() ? "--tls-cert" : "--tls-key",
                     "--tls-cert and --tls-key go together: give both (TLS) or neither "
                     "(plaintext)");
  }
  if (!files.client_ca.empty() && files.cert.empty()) {
    throw InputError("--tls-client-ca",
                     "mutual TLS needs the server's own certificate too: add --tls-cert and "
                     "--tls-key");
  }
  if (files.cert.empty()) return TransportMode::kPlaintext;
  return files.client_ca.empty() ? TransportMode::kTls : TransportMode::kMutualTls;
}

const char* TransportModeName(TransportMode mode) {
  switch (mode) {
    case TransportMode::kPlaintext: return "plaintext";
    case TransportMode::kTls: return "TLS";
    case TransportMode::kMutualTls: return "mutual TLS";
  }
  return "?";
}

std::shared_ptr<grpc::ServerCredentials> MakeServerCredentials(const TlsFiles& files) {
  const TransportMode mode = TransportModeOf(files);
  if (mode == TransportMode::kPlaintext) return grpc::InsecureServerCredentials();

  const std::string cert_pem = ReadFileBytes(files.cert, "--tls-cert");
  const std::vector<Cert> chain = ReadCertificates(cert_pem, files.cert, "--tls-cert");
  CheckDates(chain.front().get(), files.cert, "--tls-cert");

  const std::string key_pem = ReadFileBytes(files.key, "--tls-key");
  Bio key_bio = MemoryBio(key_pem);
  Key key(PEM_read_bio_PrivateKey(key_bio.get(), nullptr, NoPassphrase, nullptr));
  if (!key) {
    throw InputError("--tls-key", files.key + " holds no unencrypted PEM private key (OpenSSL: " +
                                      OpensslReason() + ")");
  }
  if (X509_check_private_key(chain.front().get(), key.get()) != 1) {
    ERR_clear_error();
    throw InputError("--tls-key", files.key + " is not the private key of the certificate in " +
                                      files.cert + " (--tls-cert)");
  }

  grpc::SslServerCredentialsOptions options(
      mode == TransportMode::kMutualTls ? GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY
                                        : GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
  options.pem_key_cert_pairs.push_back({.private_key = key_pem, .cert_chain = cert_pem});
  if (mode == TransportMode::kMutualTls) {
    options.pem_root_certs = ReadFileBytes(files.client_ca, "--tls-client-ca");
    for (const Cert& ca :
         ReadCertificates(options.pem_root_certs, files.client_ca, "--tls-client-ca")) {
      CheckDates(ca.get(), files.client_ca, "--tls-client-ca");
    }
  }
  return grpc::SslServerCredentials(options);
}

}  // namespace hgraph::server
