#include "security.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "locd/dds/topics.hpp"
#include "locd/sdk/robot_id.hpp"

extern char** environ;

namespace locd::locctl::security {
namespace fs = std::filesystem;

namespace {

constexpr const char* kOrganization = "locd";
// The governance and the permissions cover every domain id DDS Security allows (0..230).
constexpr int kMaxSecureDomain = 230;
constexpr int kCaDays = 3650;

std::string utc_text(long long seconds, const char* format) {
  const std::time_t t = static_cast<std::time_t>(seconds);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[32];
  std::strftime(text, sizeof text, format, &tm);
  return text;
}
std::string xml_date(long long seconds) { return utc_text(seconds, "%Y-%m-%dT%H:%M:%SZ"); }
std::string openssl_date(long long seconds) { return utc_text(seconds, "%Y%m%d%H%M%SZ"); }
long long end_of(const Validity& v) { return v.start + static_cast<long long>(v.days) * 86400; }

void write_file(const fs::path& file, const std::string& text, fs::perms perms = fs::perms::owner_read |
                                                                                 fs::perms::owner_write |
                                                                                 fs::perms::group_read |
                                                                                 fs::perms::others_read) {
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out) throw std::runtime_error("cannot write '" + file.string() + "'");
  }
  fs::permissions(file, perms);
}

void replace_file(const fs::path& from, const fs::path& to) {
  fs::copy_file(from, to, fs::copy_options::overwrite_existing);
}

// Runs openssl with `args`, in `directory` when given (openssl ca reads ca.cnf there).
void openssl(const Runner& run, std::vector<std::string> args, const fs::path& directory = {}) {
  args.insert(args.begin(), "openssl");
  std::string output;
  const int rc = run(args, directory.string(), output);
  if (rc != 0) {
    std::string command;
    for (const auto& a : args) command += (command.empty() ? "" : " ") + a;
    if (output.size() > 2000) output = output.substr(output.size() - 2000);
    throw std::runtime_error("'" + command + "' failed (exit " + std::to_string(rc) + "): " + output);
  }
}

void check_name(Role role, const std::string& name) {
  if (!robot_id_error(name).empty()) {
    throw std::invalid_argument(std::string(role_name(role)) + " name '" + name.substr(0, 80) +
                                "' is not allowed; allowed: 1-64 characters of [A-Za-z0-9_.-]");
  }
}

fs::path ca_dir(const fs::path& fleet) { return fleet / "ca"; }

void require_ca(const fs::path& fleet) {
  if (!fs::exists(ca_dir(fleet) / "ca.key")) {
    throw std::runtime_error("no fleet CA in '" + fleet.string() + "' (" + (ca_dir(fleet) / "ca.key").string() +
                             " is missing); make one with: locctl security init " + fleet.string());
  }
}

// openssl ca's configuration: one CA signing identities, governance and permissions, keeping a
// database of what it issued so a certificate can be revoked and a CRL issued.
std::string ca_config() {
  return R"([ ca ]
default_ca = fleet_ca

[ fleet_ca ]
dir = .
database = $dir/index.txt
new_certs_dir = $dir/certs
serial = $dir/serial
crlnumber = $dir/crlnumber
certificate = $dir/ca.pem
private_key = $dir/ca.key
default_md = sha256
default_crl_days = 3650
policy = fleet_policy
unique_subject = no
preserve = yes
copy_extensions = none

[ fleet_policy ]
organizationName = supplied
organizationalUnitName = optional
commonName = supplied

[ req ]
distinguished_name = subject
prompt = no

[ subject ]
O = locd
CN = locd fleet CA

# The CA signs certificates and CRLs, and (digitalSignature) the S/MIME governance and permissions.
[ ca_extensions ]
basicConstraints = critical, CA:true
keyUsage = critical, keyCertSign, cRLSign, digitalSignature
subjectKeyIdentifier = hash

[ identity_extensions ]
basicConstraints = critical, CA:false
keyUsage = critical, digitalSignature, keyAgreement
subjectKeyIdentifier = hash
authorityKeyIdentifier = keyid
)";
}

struct Rule {
  std::vector<const char*> topics;
  std::string partition;  // "" = the default partition
};

std::string criteria_xml(const char* kind, const Rule& rule) {
  std::string xml = std::string("        <") + kind + ">\n          <topics>";
  for (const char* topic : rule.topics) xml += std::string("<topic>") + topic + "</topic>";
  xml += "</topics>\n";
  // Without <partitions> a rule grants the default partition only.
  if (!rule.partition.empty()) xml += "          <partitions><partition>" + rule.partition + "</partition></partitions>\n";
  return xml + "        </" + kind + ">\n";
}

}  // namespace

Role parse_role(const std::string& text) {
  if (text == "robot") return Role::kRobot;
  if (text == "operator") return Role::kOperator;
  if (text == "monitor") return Role::kMonitor;
  if (text == "server") return Role::kServer;
  throw std::invalid_argument("role '" + text.substr(0, 80) + "' is not allowed; allowed: robot, operator, monitor, server");
}

const char* role_name(Role role) {
  switch (role) {
    case Role::kRobot: return "robot";
    case Role::kOperator: return "operator";
    case Role::kMonitor: return "monitor";
    case Role::kServer: return "server";
  }
  return "robot";
}

long long parse_utc(const std::string& text) {
  std::tm tm{};
  const char* end = strptime(text.c_str(), "%Y-%m-%dT%H:%M:%SZ", &tm);
  if (!end || *end != '\0') {
    throw std::invalid_argument("time '" + text.substr(0, 80) + "' is not UTC of the form 2026-11-25T10:00:00Z");
  }
  return static_cast<long long>(timegm(&tm));
}

std::string subject_openssl(Role role, const std::string& name) {
  return std::string("/O=") + kOrganization + "/OU=" + role_name(role) + "/CN=" + name;
}

std::string subject_permissions(Role role, const std::string& name) {
  return "CN=" + name + ",OU=" + role_name(role) + ",O=" + kOrganization;
}

RtpsProtection parse_rtps_protection(const std::string& text) {
  if (text == "none") return RtpsProtection::kNone;
  if (text == "sign") return RtpsProtection::kSign;
  if (text == "encrypt") return RtpsProtection::kEncrypt;
  throw std::invalid_argument("--rtps-protection = '" + text.substr(0, 80) + "'; allowed: none, sign, encrypt");
}

std::string governance_xml(RtpsProtection rtps) {
  const char* rtps_kind = rtps == RtpsProtection::kEncrypt ? "ENCRYPT" : rtps == RtpsProtection::kSign ? "SIGN" : "NONE";
  // One rule for every topic: no topic of the domain travels unprotected or without access
  // control, whatever a permissions document grants.
  return R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- locd fleet governance, made by `locctl security init`: every participant authenticates with a
     certificate of the fleet CA and presents permissions the CA signed; discovery, liveliness and
     every topic are encrypted; every topic is access controlled (read and write); whole RTPS
     messages: )" + std::string(rtps_kind) + R"( (locctl security init --rtps-protection). -->
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>)" +
         std::to_string(kMaxSecureDomain) + R"(</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>)" + std::string(rtps_kind) + R"(</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
)";
}

std::string permissions_xml(Role role, const std::string& name, const Validity& validity) {
  using namespace topics;
  const std::vector<const char*> sensors = {kOdometry, kImu, kScan, kCloud, kImage, kDetections};
  const std::vector<const char*> requests = {kSessionRequest, kInitialPose, kMapSaveRequest};
  const std::vector<const char*> outputs = {kPose, kGrid, kMapCloud, kLandmarkMap, kDiagnostics, kExplorationGoal,
                                            kSessionStatus};
  const auto join = [](std::initializer_list<std::vector<const char*>> lists) {
    std::vector<const char*> all;
    for (const auto& l : lists) all.insert(all.end(), l.begin(), l.end());
    return all;
  };
  const std::string own = robot_partition(name);
  const std::string every = kAllRobotsPartition;
  std::vector<std::pair<const char*, Rule>> rules;  // publish / subscribe
  switch (role) {
    case Role::kRobot:  // feeds and steers its own robot, reads its own outputs
      rules = {{"publish", {join({sensors, requests, {kGroundTruth}}), own}},
               {"subscribe", {outputs, own}},
               {"subscribe", {{kServerInfo}, ""}}};
      break;
    case Role::kOperator:  // steers any robot, reads everything but the raw sensors
      rules = {{"publish", {requests, every}},
               {"subscribe", {join({outputs, {kGroundTruth}}), every}},
               {"subscribe", {{kServerInfo}, ""}}};
      break;
    case Role::kMonitor:  // reads everything, writes nothing
      rules = {{"subscribe", {join({sensors, requests, outputs, {kGroundTruth}}), every}},
               {"subscribe", {{kServerInfo}, ""}}};
      break;
    case Role::kServer:  // reads every robot's inputs, writes every robot's outputs, announces itself
      rules = {{"subscribe", {join({sensors, requests}), every}},
               {"publish", {outputs, every}},
               {"publish", {{kServerInfo, kServingClaim, kResumeState}, ""}},
               {"subscribe", {{kServerInfo, kServingClaim, kResumeState}, ""}}};
      break;
  }
  std::string xml = std::string(R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- Permissions of )") + role_name(role) + " '" + name + R"(', made by `locctl security`. -->
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name=")" + role_name(role) + "." + name + R"(">
      <subject_name>)" + subject_permissions(role, name) + R"(</subject_name>
      <validity><not_before>)" + xml_date(validity.start) + "</not_before><not_after>" + xml_date(end_of(validity)) +
                    R"(</not_after></validity>
      <allow_rule>
        <domains><id_range><min>0</min><max>)" + std::to_string(kMaxSecureDomain) + R"(</max></id_range></domains>
)";
  for (const auto& [kind, rule] : rules) xml += criteria_xml(kind, rule);
  xml += R"(      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
)";
  return xml;
}

std::string cyclone_security_xml(const std::string& folder) {
  const std::string f = "file://" + folder + "/";
  return R"(<CycloneDDS xmlns="https://cdds.io/config">
  <Domain id="any">
    <Security>
      <Authentication>
        <Library path="dds_security_auth" initFunction="init_authentication" finalizeFunction="finalize_authentication"/>
        <IdentityCA>)" + f + R"(ca.pem</IdentityCA>
        <IdentityCertificate>)" + f + R"(cert.pem</IdentityCertificate>
        <PrivateKey>)" + f + R"(key.pem</PrivateKey>
        <CRL>)" + f + R"(crl.pem</CRL>
      </Authentication>
      <AccessControl>
        <Library path="dds_security_ac" initFunction="init_access_control" finalizeFunction="finalize_access_control"/>
        <PermissionsCA>)" + f + R"(ca.pem</PermissionsCA>
        <Governance>)" + f + R"(governance.p7s</Governance>
        <Permissions>)" + f + R"(permissions.p7s</Permissions>
      </AccessControl>
      <Cryptographic>
        <Library path="dds_security_crypto" initFunction="init_crypto" finalizeFunction="finalize_crypto"/>
      </Cryptographic>
    </Security>
  </Domain>
</CycloneDDS>
)";
}

Runner system_runner() {
  return [](const std::vector<std::string>& argv, const std::string& directory, std::string& output) -> int {
    int pipe_fds[2];
    if (pipe(pipe_fds) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDERR_FILENO);
    posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
    if (!directory.empty()) posix_spawn_file_actions_addchdir_np(&actions, directory.c_str());
    std::vector<std::string> store = argv;
    std::vector<char*> args;
    for (auto& a : store) args.push_back(a.data());
    args.push_back(nullptr);
    pid_t pid = -1;
    const int rc = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    close(pipe_fds[1]);
    if (rc != 0) {
      close(pipe_fds[0]);
      throw std::runtime_error("cannot run " + argv[0] + ": " + std::strerror(rc) +
                               " (scripts/bootstrap installs openssl)");
    }
    char buffer[4096];
    ssize_t n;
    while ((n = read(pipe_fds[0], buffer, sizeof buffer)) > 0) output.append(buffer, static_cast<size_t>(n));
    close(pipe_fds[0]);
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  };
}

void init(const fs::path& fleet, const Validity& validity, const Runner& run, RtpsProtection rtps) {
  const fs::path ca = fs::absolute(ca_dir(fleet));
  if (fs::exists(ca)) throw std::runtime_error("'" + ca.string() + "' exists already; a fleet has one CA");
  fs::create_directories(ca / "certs");
  fs::permissions(ca, fs::perms::owner_all);
  write_file(ca / "ca.cnf", ca_config());
  write_file(ca / "index.txt", "");
  write_file(ca / "serial", "1000\n");
  write_file(ca / "crlnumber", "1000\n");
  const fs::path key = ca / "ca.key";
  openssl(run, {"genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:P-256", "-out", key.string()});
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write);
  // Self-signed through `openssl ca`, so its validity can start in the past like any identity's.
  const fs::path request = ca / "ca.csr";
  openssl(run, {"req", "-new", "-config", (ca / "ca.cnf").string(), "-key", key.string(), "-out", request.string()});
  const Validity ca_validity{validity.start, kCaDays};
  openssl(run, {"ca", "-batch", "-selfsign", "-config", "ca.cnf", "-keyfile", "ca.key", "-in", "ca.csr",
                "-extensions", "ca_extensions", "-startdate", openssl_date(ca_validity.start), "-enddate",
                openssl_date(end_of(ca_validity)), "-notext", "-out", "ca.pem"}, ca);
  openssl(run, {"ca", "-batch", "-config", "ca.cnf", "-gencrl", "-out", "crl.pem"}, ca);
  fs::remove(request);
  write_file(fleet / "governance.xml", governance_xml(rtps));
  openssl(run, {"smime", "-sign", "-text", "-in", (fleet / "governance.xml").string(), "-signer",
                (ca / "ca.pem").string(), "-inkey", key.string(), "-out", (fleet / "governance.p7s").string()});
}

fs::path make_identity(const fs::path& fleet, Role role, const std::string& name, const Validity& validity,
                       const Runner& run) {
  check_name(role, name);
  require_ca(fleet);
  if (validity.days < 1) throw std::invalid_argument("validity of " + std::to_string(validity.days) + " days; at least 1");
  const fs::path ca = fs::absolute(ca_dir(fleet));
  const fs::path dir = fs::absolute(fleet / role_name(role) / name);
  if (fs::exists(dir)) {
    throw std::runtime_error("'" + dir.string() + "' exists already; revoke it (locctl security revoke) and remove it "
                             "before making a new identity of that name");
  }
  fs::create_directories(dir);
  const fs::path key = dir / "key.pem";
  openssl(run, {"genpkey", "-algorithm", "EC", "-pkeyopt", "ec_paramgen_curve:P-256", "-out", key.string()});
  fs::permissions(key, fs::perms::owner_read | fs::perms::owner_write);
  const fs::path request = dir / "cert.csr";
  openssl(run, {"req", "-new", "-key", key.string(), "-subj", subject_openssl(role, name), "-out", request.string()});
  openssl(run, {"ca", "-batch", "-config", "ca.cnf", "-extensions", "identity_extensions", "-in", request.string(),
                "-startdate", openssl_date(validity.start), "-enddate", openssl_date(end_of(validity)), "-notext",
                "-out", (dir / "cert.pem").string()}, ca);
  fs::remove(request);
  write_file(dir / "permissions.xml", permissions_xml(role, name, validity));
  openssl(run, {"smime", "-sign", "-text", "-in", (dir / "permissions.xml").string(), "-signer",
                (ca / "ca.pem").string(), "-inkey", (ca / "ca.key").string(), "-out",
                (dir / "permissions.p7s").string()});
  replace_file(ca / "ca.pem", dir / "ca.pem");
  replace_file(ca / "crl.pem", dir / "crl.pem");
  replace_file(fleet / "governance.p7s", dir / "governance.p7s");
  write_file(dir / "cyclonedds.xml",
             "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!-- DDS Security of " + std::string(role_name(role)) +
                 " '" + name + "' (locctl security). Use it with the network config, e.g.\n"
                 "     CYCLONEDDS_URI=file:///path/to/network.xml,file://" + (dir / "cyclonedds.xml").string() +
                 " -->\n" + cyclone_security_xml(dir.string()));
  return dir;
}

std::vector<fs::path> revoke(const fs::path& fleet, Role role, const std::string& name, const Runner& run) {
  check_name(role, name);
  require_ca(fleet);
  const fs::path ca = fs::absolute(ca_dir(fleet));
  const fs::path cert = fs::absolute(fleet / role_name(role) / name / "cert.pem");
  if (!fs::exists(cert)) throw std::runtime_error("no certificate '" + cert.string() + "' to revoke");
  openssl(run, {"ca", "-batch", "-config", "ca.cnf", "-revoke", cert.string()}, ca);
  openssl(run, {"ca", "-batch", "-config", "ca.cnf", "-gencrl", "-out", "crl.pem"}, ca);
  std::vector<fs::path> updated;
  for (const char* r : {"robot", "operator", "monitor", "server"}) {
    std::error_code ec;
    if (!fs::is_directory(fleet / r, ec)) continue;
    for (const auto& entry : fs::directory_iterator(fleet / r)) {
      if (!fs::exists(entry.path() / "crl.pem")) continue;
      replace_file(ca / "crl.pem", entry.path() / "crl.pem");
      updated.push_back(entry.path());
    }
  }
  return updated;
}

}  // namespace locd::locctl::security
