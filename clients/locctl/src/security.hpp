// locctl security: a fleet's certificate authority, its identities (robot, operator, monitor,
// server) and their signed permissions, made with the openssl command line. README "Security"
// walks through it; config/dds/secure.xml is the Cyclone config every identity folder fills in.
//
//   FLEET/ca/                 the CA: ca.key (private, 0600), ca.pem, ca.cnf and openssl's
//                             database (index.txt, serial, crlnumber), crl.pem (revoked certificates)
//   FLEET/governance.xml|.p7s what the domain protects (signed): every topic access controlled and
//                             encrypted, discovery and liveliness encrypted, no unauthenticated peers
//   FLEET/<role>/<name>/      one identity, everything it needs and nothing of the CA's secrets:
//                             key.pem (0600), cert.pem, ca.pem, crl.pem, governance.p7s,
//                             permissions.xml (readable) and permissions.p7s (signed), cyclonedds.xml
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace locd::locctl::security {

enum class Role { kRobot, kOperator, kMonitor, kServer };

// "robot" -> kRobot, ...; throws std::invalid_argument naming the allowed roles.
Role parse_role(const std::string& text);
const char* role_name(Role role);

// When a certificate and its permissions are valid: from `start` (UTC seconds since the epoch)
// for `days` days.
struct Validity {
  long long start = 0;
  int days = 365;
};

// "2026-11-25T10:00:00Z" -> seconds since the epoch (UTC); throws std::invalid_argument.
long long parse_utc(const std::string& text);

// The documents, pure functions of their inputs.
std::string subject_openssl(Role role, const std::string& name);      // "/O=locd/OU=robot/CN=r1"
std::string subject_permissions(Role role, const std::string& name);  // "CN=r1,OU=robot,O=locd"
// What the governance asks of whole RTPS messages (rtps_protection_kind), beyond the per-topic
// data, metadata, discovery and liveliness encryption it always asks for: none (each topic's
// payload is still encrypted; message headers and the submessage structure are not), sign or
// encrypt (SROS2's choice: the whole message, at a cost README measures).
enum class RtpsProtection { kNone, kSign, kEncrypt };
RtpsProtection parse_rtps_protection(const std::string& text);  // none | sign | encrypt; throws invalid_argument
std::string governance_xml(RtpsProtection rtps = RtpsProtection::kNone);
std::string permissions_xml(Role role, const std::string& name, const Validity& validity);
// The <Security> config of one identity whose files are in `folder` (an absolute path, or
// "${LOCD_IDENTITY}" for config/dds/secure.xml).
std::string cyclone_security_xml(const std::string& folder);

// Runs a program (no shell) in `directory` ("" = this one) and returns its exit code; its output
// goes to `output`.
using Runner =
    std::function<int(const std::vector<std::string>& argv, const std::string& directory, std::string& output)>;
Runner system_runner();

// The steps. Each throws std::runtime_error naming the file or the openssl command that failed,
// and never overwrites an existing CA or identity.
void init(const std::filesystem::path& fleet, const Validity& validity, const Runner& run,
          RtpsProtection rtps = RtpsProtection::kNone);
std::filesystem::path make_identity(const std::filesystem::path& fleet, Role role, const std::string& name,
                                    const Validity& validity, const Runner& run);
// Revokes the identity's certificate, reissues FLEET/ca/crl.pem and copies it into every identity
// folder under FLEET. Returns the folders updated.
std::vector<std::filesystem::path> revoke(const std::filesystem::path& fleet, Role role, const std::string& name,
                                          const Runner& run);

}  // namespace locd::locctl::security
