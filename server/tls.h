// Transport security of the gRPC port (--tls-cert, --tls-key, --tls-client-ca): plaintext, TLS,
// or mutual TLS where every client must present a certificate signed by the given CA. The files
// are read and checked once at start (PEM, key matching the certificate, validity dates), so that
// a wrong file is a clear error naming the flag rather than a port that refuses every handshake.
#pragma once

#include <grpcpp/security/server_credentials.h>

#include <memory>
#include <string>

namespace hgraph::server {

struct TlsFiles {
  std::string cert;       // PEM certificate chain of the server (leaf first)
  std::string key;        // PEM private key of that certificate, unencrypted
  std::string client_ca;  // PEM CA certificate(s) client certificates must chain to; mTLS
};

enum class TransportMode { kPlaintext, kTls, kMutualTls };

// The mode the flags ask for. Throws InputError naming the flag when only one of cert and key is
// given, or a client CA without them.
TransportMode TransportModeOf(const TlsFiles& files);
const char* TransportModeName(TransportMode mode);  // "plaintext", "TLS", "mutual TLS"

// Credentials for the listening port. Throws hgraph::Error naming the flag and the problem when
// a file cannot be read, is not PEM, the key does not belong to the certificate, a certificate
// is expired or not yet valid, or the client CA file holds no certificate. Never puts a key's
// bytes in a message.
std::shared_ptr<grpc::ServerCredentials> MakeServerCredentials(const TlsFiles& files);

}  // namespace hgraph::server
