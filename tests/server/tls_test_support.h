// Certificates made on the spot for the TLS tests, so no private key lives in the tree: a P-256
// key and a self-signed certificate for 127.0.0.1 and localhost, written as PEM files (and read
// back).
#pragma once

#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <stdexcept>
#include <string>

namespace mocap::test {

struct TlsFiles {
  std::string cert;
  std::string key;
};

// A PEM file's text, as gRPC's credentials take it.
inline std::string fileText(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Writes dir/name.crt and dir/name.key, the certificate valid from `valid_from_days` to
// `valid_to_days` days from now; `passphrase`, if not empty, encrypts the key.
inline TlsFiles writeSelfSignedCertificate(const std::filesystem::path& dir,
                                           const std::string& name, long valid_from_days = -1,
                                           long valid_to_days = 2,
                                           const std::string& passphrase = "") {
  std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)> key(EVP_EC_gen("P-256"), EVP_PKEY_free);
  std::unique_ptr<X509, decltype(&X509_free)> cert(X509_new(), X509_free);
  if (!key || !cert) throw std::runtime_error("OpenSSL could not make a key");
  X509_set_version(cert.get(), 2);
  ASN1_INTEGER_set(X509_get_serialNumber(cert.get()), 1);
  constexpr long kDay = 24 * 3600;
  X509_gmtime_adj(X509_getm_notBefore(cert.get()), valid_from_days * kDay);
  X509_gmtime_adj(X509_getm_notAfter(cert.get()), valid_to_days * kDay);
  X509_set_pubkey(cert.get(), key.get());
  X509_NAME* subject = X509_get_subject_name(cert.get());
  X509_NAME_add_entry_by_txt(subject, "CN", MBSTRING_ASC,
                             reinterpret_cast<const unsigned char*>("localhost"), -1, -1, 0);
  X509_set_issuer_name(cert.get(), subject);
  X509V3_CTX context;
  X509V3_set_ctx_nodb(&context);
  X509V3_set_ctx(&context, cert.get(), cert.get(), nullptr, nullptr, 0);
  X509_EXTENSION* names =
      X509V3_EXT_conf_nid(nullptr, &context, NID_subject_alt_name, "IP:127.0.0.1,DNS:localhost");
  if (!names) throw std::runtime_error("OpenSSL could not make the certificate's names");
  X509_add_ext(cert.get(), names, -1);
  X509_EXTENSION_free(names);
  if (X509_sign(cert.get(), key.get(), EVP_sha256()) == 0)
    throw std::runtime_error("OpenSSL could not sign the certificate");

  const TlsFiles files{(dir / (name + ".crt")).string(), (dir / (name + ".key")).string()};
  auto write = [](const std::string& path, auto&& emit) {
    std::unique_ptr<BIO, decltype(&BIO_free)> out(BIO_new_file(path.c_str(), "w"), BIO_free);
    if (!out || emit(out.get()) != 1) throw std::runtime_error("cannot write " + path);
  };
  write(files.cert, [&](BIO* out) { return PEM_write_bio_X509(out, cert.get()); });
  write(files.key, [&](BIO* out) {
    auto* phrase = reinterpret_cast<const unsigned char*>(passphrase.data());
    return passphrase.empty()
               ? PEM_write_bio_PrivateKey(out, key.get(), nullptr, nullptr, 0, nullptr, nullptr)
               : PEM_write_bio_PrivateKey(out, key.get(), EVP_aes_256_cbc(), phrase,
                                          static_cast<int>(passphrase.size()), nullptr, nullptr);
  });
  return files;
}

}  // namespace mocap::test
