// eProsima Fast DDS (Debian libfastrtps-dev 2.9) peer of the capsule graph, as an rclcpp node on
// rmw_fastrtps_cpp sees it: topics rt/..., services rq/<service>Request and rr/<service>Reply,
// DDS type names pkg::msg::dds_::Name_, XCDR1, and rmw_fastrtps's request/reply correlation (the
// request's related_sample_identity carries the client's reply reader GUID; the reply's
// related_sample_identity is the request's sample identity).
//
// Usage (inside a loopback-only network namespace, see tests/peers/netns_run.sh):
//   fastdds_peer state [--samples N]          read rt/capsule/state, check it, print JSON
//   fastdds_peer force --force F              command the plant (no controller): F applied,
//                                             NaN refused, zero after silence
//   fastdds_peer set-mode MODE GAIN [--service S]
//                                             call /capsule_controller/set_mode, print the answer
//   fastdds_peer params --node N [--set NAME=DOUBLE]... [--late-s S]
//                                             (--late-s: call set_mode first, make the parameter
//                                             clients S s later, as a long-lived node would)
//                                             list, get and set parameters as `ros2 param` does
//   fastdds_peer lifecycle T... [--node N]  change_state by label (rmw_fastrtps's mapping, as
//                                             `ros2 lifecycle set`), get_state after each; JSON
//   fastdds_peer estop [--service S]          engage the emergency stop, time the answer [ms],
//                                             release it; JSON
//   fastdds_peer move DIST [--action A]      a Move goal: send_goal, get_result, the feedback
//                                             read meanwhile; JSON
//   fastdds_peer bad KIND [--service S]       bad input, then a good call (must be answered):
//                                             KIND = identity (no reply reader GUID, unknown
//                                             sequence), cyclone (the request in the
//                                             rmw_cyclonedds layout on the same topic), layout
//                                             (the ActuatorForce name with another layout)
// Fast DDS uses UDPv4 on 127.0.0.1 only (builtin transports off, interface whitelist).
// Secured as rmw_fastrtps secures a node when ROS_SECURITY_ENABLE=true: the builtin plugins
// (PKI-DH, Access-Permissions, AES-GCM-GMAC) on the six files of the enclave
// $ROS_SECURITY_KEYSTORE/enclaves$ROS_SECURITY_ENCLAVE_OVERRIDE.
// Exit status 0 = the checks held; 1 = a check failed (the reason on stderr).

#include <algorithm>
#include <climits>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/rtps/common/WriteParams.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>

#include "types.hpp"

using namespace eprosima::fastdds::dds;
using eprosima::fastrtps::rtps::GUID_t;
using eprosima::fastrtps::rtps::WriteParams;
using Clock = std::chrono::steady_clock;

[[noreturn]] static void fail(const std::string& why) {
  std::fprintf(stderr, "fastdds_peer: %s\n", why.c_str());
  std::fflush(nullptr);
  // no destructors: Fast DDS 2.9 crashes tearing down a participant whose writer its access
  // control refused
  std::_Exit(1);
}

/// Now + S seconds.
static Clock::time_point after(double s) {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

static double secs(const builtin_interfaces::msg::Time& t) { return t.sec + 1e-9 * t.nanosec; }

static std::string json_str(const std::string& s) {
  std::string o = "\"";
  for (char ch : s) {
    if (ch == '"' || ch == '\\') o += '\\';
    if (static_cast<unsigned char>(ch) < 0x20) { o += ' '; continue; }
    o += ch;
  }
  return o + "\"";
}

static std::string num(double v) {
  if (!std::isfinite(v)) return "null";
  std::ostringstream o;
  o.precision(17);
  o << v;
  return o.str();
}

/// The DDS Security properties of the enclave the ROS_SECURITY_* variables name (none unless
/// ROS_SECURITY_ENABLE is exactly "true"), under the names rmw_fastrtps gives them.
static void secure(DomainParticipantQos& qos) {
  const char* enable = std::getenv("ROS_SECURITY_ENABLE");
  if (!enable || std::string(enable) != "true") return;
  const char* ks = std::getenv("ROS_SECURITY_KEYSTORE");
  const char* enclave = std::getenv("ROS_SECURITY_ENCLAVE_OVERRIDE");
  if (!ks || !enclave || enclave[0] != '/')
    fail("ROS_SECURITY_ENABLE=true: set ROS_SECURITY_KEYSTORE and ROS_SECURITY_ENCLAVE_OVERRIDE=/name");
  std::string dir = std::string(ks) + "/enclaves" + enclave;
  char real[PATH_MAX];
  if (!realpath(dir.c_str(), real)) fail("no enclave directory " + dir);
  auto file = [&](const char* name) { return "file://" + std::string(real) + "/" + name; };
  auto& p = qos.properties().properties();
  p.emplace_back("dds.sec.auth.plugin", "builtin.PKI-DH");
  p.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_ca", file("identity_ca.cert.pem"));
  p.emplace_back("dds.sec.auth.builtin.PKI-DH.identity_certificate", file("cert.pem"));
  p.emplace_back("dds.sec.auth.builtin.PKI-DH.private_key", file("key.pem"));
  p.emplace_back("dds.sec.access.plugin", "builtin.Access-Permissions");
  p.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions_ca",
                 file("permissions_ca.cert.pem"));
  p.emplace_back("dds.sec.access.builtin.Access-Permissions.governance", file("governance.p7s"));
  p.emplace_back("dds.sec.access.builtin.Access-Permissions.permissions", file("permissions.p7s"));
  p.emplace_back("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
  std::fprintf(stderr, "fastdds_peer: secured with the enclave %s (%s)\n", enclave, real);
}

/// One participant on loopback only, with the topics, writers and readers it made.
class Peer {
 public:
  Peer() {
    DomainParticipantQos qos;
    qos.name("fastdds_peer");
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->interfaceWhiteList.push_back("127.0.0.1");
    qos.transport().user_transports.push_back(udp);
    qos.transport().use_builtin_transports = false;
    secure(qos);
    const char* dom = std::getenv("ROS_DOMAIN_ID");
    int domain = dom ? std::atoi(dom) : 0;
    dp_ = DomainParticipantFactory::get_instance()->create_participant(domain, qos);
    if (!dp_) fail("cannot create a Fast DDS participant");
    pub_ = dp_->create_publisher(PUBLISHER_QOS_DEFAULT);
    sub_ = dp_->create_subscriber(SUBSCRIBER_QOS_DEFAULT);
  }
  ~Peer() {
    dp_->delete_contained_entities();
    DomainParticipantFactory::get_instance()->delete_participant(dp_);
  }

  template <class T>
  Topic* topic(const std::string& name) {
    TypeSupport ts(new RosType<T>());
    std::string type = T::dds_name();
    // two C++ layouts under one DDS type name (bad input) need two registrations' names apart
    if (types_.count(type) == 0) {
      if (ts.register_type(dp_) != ReturnCode_t::RETCODE_OK) fail("cannot register " + type);
      types_[type] = true;
    }
    auto it = topics_.find(name);
    if (it != topics_.end()) return it->second;
    Topic* t = dp_->create_topic(name, type, TOPIC_QOS_DEFAULT);
    if (!t) fail("cannot create topic " + name);
    topics_[name] = t;
    return t;
  }

  /// A writer with the rmw default QoS (reliable, volatile, keep last 10).
  template <class T>
  DataWriter* writer(const std::string& name) {
    DataWriterQos q = DATAWRITER_QOS_DEFAULT;
    q.reliability().kind = RELIABLE_RELIABILITY_QOS;
    q.durability().kind = VOLATILE_DURABILITY_QOS;
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = 10;
    DataWriter* w = pub_->create_datawriter(topic<T>(name), q);
    if (!w) fail("cannot create a writer on " + name);
    return w;
  }

  template <class T>
  DataReader* reader(const std::string& name, int depth = 10) {
    DataReaderQos q = DATAREADER_QOS_DEFAULT;
    q.reliability().kind = RELIABLE_RELIABILITY_QOS;
    q.durability().kind = VOLATILE_DURABILITY_QOS;
    q.history().kind = KEEP_LAST_HISTORY_QOS;
    q.history().depth = depth;
    DataReader* r = sub_->create_datareader(topic<T>(name), q);
    if (!r) fail("cannot create a reader on " + name);
    return r;
  }

  DomainParticipant* dp_;

 private:
  Publisher* pub_;
  Subscriber* sub_;
  std::map<std::string, bool> types_;
  std::map<std::string, Topic*> topics_;
};

/// Takes every sample waiting in R (valid data only).
template <class T>
static std::vector<T> take_all(DataReader* r) {
  std::vector<T> out;
  T s;
  SampleInfo info;
  while (r->take_next_sample(&s, &info) == ReturnCode_t::RETCODE_OK) {
    if (info.valid_data) out.push_back(s);
  }
  return out;
}

/// Waits until endpoint E has matched an endpoint on the other side (`side`), by its matched
/// status; fails naming the other side and WHAT after `timeout_s`.
template <class Endpoint, class Status>
static void wait_for_match(const Endpoint* e, ReturnCode_t (Endpoint::*matched)(Status&) const,
                           const char* side, double timeout_s, const std::string& what) {
  auto end = after(timeout_s);
  Status st;
  while (Clock::now() < end) {
    (e->*matched)(st);
    if (st.current_count > 0) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  fail(std::string("no ") + side + " matched " + what + " within " + num(timeout_s) + " s");
}

static void wait_matched(DataWriter* w, double timeout_s, const std::string& what) {
  wait_for_match(w, &DataWriter::get_publication_matched_status, "subscriber", timeout_s, what);
}

static void wait_matched(DataReader* r, double timeout_s, const std::string& what) {
  wait_for_match(r, &DataReader::get_subscription_matched_status, "publisher", timeout_s, what);
}

/// A service client in rmw_fastrtps's mapping.
template <class Req, class Rep>
class Client {
 public:
  Client(Peer& p, const std::string& service, double timeout_s)
      : service_(service), timeout_(timeout_s) {
    std::string s = service[0] == '/' ? service.substr(1) : service;
    w_ = p.writer<Req>("rq/" + s + "Request");
    r_ = p.reader<Rep>("rr/" + s + "Reply", 100);
    wait_matched(w_, timeout_, "rq/" + s + "Request");
    wait_matched(r_, timeout_, "rr/" + s + "Reply");
  }

  /// Sends REQ (again after 0.5 s, then 1, 2 and every 4 s: a first write can race discovery)
  /// until a reply to one of the requests sent comes (the first's can come after the second
  /// was sent, on a loaded host).
  Rep call(Req req) {
    auto end = after(timeout_);
    std::vector<eprosima::fastrtps::rtps::SequenceNumber_t> sent;
    double wait = 0.5;
    while (Clock::now() < end) {
      WriteParams wp;
      wp.related_sample_identity().writer_guid(r_->guid());
      if (!w_->write(&req, wp)) fail("cannot write a " + service_ + " request");
      sent.push_back(wp.sample_identity().sequence_number());
      auto resend = std::min(end, after(wait));
      wait = std::min(2 * wait, 4.0);
      Rep answer;
      auto answers_sent = [&](const Rep& rep, const auto& rel) {
        bool ours = rel.writer_guid() == r_->guid() || rel.writer_guid() == w_->guid();
        bool answers = ours && std::find(sent.begin(), sent.end(), rel.sequence_number()) != sent.end();
        if (answers) answer = rep;
        return answers;
      };
      while (Clock::now() < resend) {
        if (take_replies(answers_sent)) return answer;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    }
    fail("no " + service_ + " reply within " + num(timeout_) + " s");
  }

  /// Writes REQ with the given write parameters; says how a reply in WAIT s was addressed:
  /// "none", "request" (related to the request's own sample identity: rmw_fastrtps's fallback
  /// when the request names no reply reader) or "other".
  std::string write_raw(Req req, WriteParams& wp, double wait_s) {
    if (!w_->write(&req, wp)) fail("cannot write a " + service_ + " request");
    auto sent = wp.sample_identity();
    auto end = after(wait_s);
    std::string addressed;
    auto first = [&](const Rep&, const auto& rel) {
      bool to_request = rel.writer_guid() == w_->guid() &&
                        rel.sequence_number() == sent.sequence_number();
      addressed = to_request ? "request" : "other";
      return true;
    };
    while (Clock::now() < end) {
      if (take_replies(first)) return addressed;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return "none";
  }

 private:
  /// Takes the replies waiting (valid data only) until TAKEN(reply, the sample identity it is
  /// related to) says it was the one; true if one was, the rest left in the reader.
  template <class F>
  bool take_replies(F&& taken) {
    Rep rep;
    SampleInfo info;
    while (r_->take_next_sample(&rep, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data && taken(rep, info.related_sample_identity)) return true;
    }
    return false;
  }

  std::string service_;
  double timeout_;
  DataWriter* w_;
  DataReader* r_;
};

static std::map<std::string, std::string> flags(int argc, char** argv, int from,
                                                std::vector<std::string>* sets = nullptr) {
  std::map<std::string, std::string> f;
  for (int i = from; i < argc; i++) {
    std::string a = argv[i];
    if (a.rfind("--", 0) != 0 || i + 1 >= argc) fail("bad argument " + a);
    if (a == "--set" && sets) sets->push_back(argv[++i]);
    else f[a.substr(2)] = argv[++i];
  }
  return f;
}

static double flag(const std::map<std::string, std::string>& f, const std::string& k, double d) {
  auto it = f.find(k);
  return it == f.end() ? d : std::strtod(it->second.c_str(), nullptr);
}

// --- state: the plant's samples as published
static int cmd_state(int argc, char** argv) {
  auto f = flags(argc, argv, 2);
  size_t n = static_cast<size_t>(flag(f, "samples", 200));
  double timeout = flag(f, "timeout", 20);
  Peer p;
  DataReader* r = p.reader<capsule_msgs::msg::CapsuleState>("rt/capsule/state", 1000);
  std::vector<capsule_msgs::msg::CapsuleState> got;
  auto end = after(timeout);
  while (got.size() < n && Clock::now() < end) {
    for (auto& s : take_all<capsule_msgs::msg::CapsuleState>(r)) got.push_back(s);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  if (got.size() < n) fail("got " + std::to_string(got.size()) + " of " + std::to_string(n) +
                           " state samples");
  for (size_t i = 0; i < got.size(); i++) {
    const auto& s = got[i];
    if (!std::isfinite(s.mass_position) || !std::isfinite(s.capsule_position) ||
        !std::isfinite(s.actuator_force))
      fail("a state with non-finite values");
    if (s.header.frame_id != "odom") fail("frame_id " + s.header.frame_id);
    if (i > 0 && (s.seq <= got[i - 1].seq || secs(s.header.stamp) <= secs(got[i - 1].header.stamp)))
      fail("seq or stamp not increasing");
  }
  double rate = (got.back().seq - got.front().seq) /
                (secs(got.back().header.stamp) - secs(got.front().header.stamp));
  for (const auto& s : got)
    if (std::fabs(secs(s.header.stamp) - s.seq / rate) > 1e-6) fail("stamps are not seq / rate");
  double lo = 1e300, hi = -1e300;
  for (const auto& s : got) { lo = std::min(lo, s.mass_position); hi = std::max(hi, s.mass_position); }
  std::printf("{\"samples\": %zu, \"rate_hz\": %s, \"first_seq\": %llu, \"mass_travel_m\": %s}\n",
              got.size(), num(rate).c_str(), static_cast<unsigned long long>(got.front().seq),
              num(hi - lo).c_str());
  return 0;
}

// --- force: commanding the plant, as a controller on rmw_fastrtps would
static int cmd_force(int argc, char** argv) {
  auto f = flags(argc, argv, 2);
  double force = flag(f, "force", 0.05);
  Peer p;
  DataReader* r = p.reader<capsule_msgs::msg::CapsuleState>("rt/capsule/state", 1000);
  DataWriter* w = p.writer<capsule_msgs::msg::ActuatorForce>("rt/capsule/actuator_force");
  wait_matched(w, 15, "rt/capsule/actuator_force");
  capsule_msgs::msg::CapsuleState latest;
  bool have = false;
  // answers the newest state with F for S seconds; returns the states seen
  auto pump = [&](double value, double seconds) {
    std::vector<capsule_msgs::msg::CapsuleState> seen;
    auto end = after(seconds);
    while (Clock::now() < end) {
      for (auto& s : take_all<capsule_msgs::msg::CapsuleState>(r)) {
        latest = s;
        have = true;
        seen.push_back(s);
      }
      if (have) {
        capsule_msgs::msg::ActuatorForce cmd;
        cmd.header.stamp = latest.header.stamp;
        cmd.header.frame_id = "";
        cmd.state_seq = latest.seq;
        cmd.force = value;
        w->write(&cmd);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return seen;
  };
  pump(force, 1.0);
  if (!have) fail("no state from the plant");
  auto seen = pump(force, 1.5);
  size_t applied = 0;
  for (const auto& s : seen)
    if (std::fabs(s.actuator_force - force) < 1e-12) applied++;
  if (applied == 0) fail("the force " + num(force) + " N was never applied");
  uint32_t before = latest.rejected_commands;
  auto nan_seen = pump(std::nan(""), 1.0);
  uint32_t after = latest.rejected_commands;
  for (const auto& s : nan_seen)
    if (!std::isfinite(s.actuator_force)) fail("a NaN command was applied");
  // silence: the watchdog falls back to zero
  std::vector<capsule_msgs::msg::CapsuleState> quiet;
  auto end = Clock::now() + std::chrono::seconds(3);
  bool zero = false;
  while (Clock::now() < end && !zero) {
    for (auto& s : take_all<capsule_msgs::msg::CapsuleState>(r))
      if (s.actuator_force == 0.0 && s.command_stale) zero = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!zero) fail("the force did not fall back to zero after the commands stopped");
  std::printf("{\"applied_samples\": %zu, \"refused_before\": %u, \"refused_after\": %u, "
              "\"stale_fallback\": true}\n", applied, before, after);
  return 0;
}

static void print_set_mode(const capsule_msgs::srv::SetMode_Response& r) {
  std::printf("{\"accepted\": %s, \"mode\": %u, \"gain\": %s, \"reason\": %s}\n",
              r.accepted ? "true" : "false", r.mode, num(r.gain).c_str(),
              json_str(r.reason).c_str());
}

static capsule_msgs::srv::SetMode_Request set_mode_request(int mode, double gain) {
  capsule_msgs::srv::SetMode_Request q;
  q.mode = static_cast<uint8_t>(mode);
  q.gain = gain;
  return q;
}

// --- set-mode: the controller's service in rmw_fastrtps's mapping
static int cmd_set_mode(int argc, char** argv) {
  if (argc < 4) fail("set-mode MODE GAIN");
  int mode = std::atoi(argv[2]);
  double gain = std::strtod(argv[3], nullptr);
  auto f = flags(argc, argv, 4);
  std::string service = f.count("service") ? f["service"] : "capsule_controller/set_mode";
  Peer p;
  Client<capsule_msgs::srv::SetMode_Request, capsule_msgs::srv::SetMode_Response> c(
      p, service, flag(f, "timeout", 20));
  print_set_mode(c.call(set_mode_request(mode, gain)));
  return 0;
}

static std::string value_json(const rcl_interfaces::msg::ParameterValue& v) {
  switch (v.type) {
    case 1: return v.bool_value ? "true" : "false";
    case 2: return std::to_string(v.integer_value);
    case 3: return num(v.double_value);
    case 4: return json_str(v.string_value);
    default: return "null";
  }
}

// --- params: rcl_interfaces services as `ros2 param list/get/set` call them
static int cmd_params(int argc, char** argv) {
  std::vector<std::string> sets;
  auto f = flags(argc, argv, 2, &sets);
  std::string node = f.count("node") ? f["node"] : "/capsule_controller";
  if (node[0] == '/') node = node.substr(1);
  double timeout = flag(f, "timeout", 20);
  double late = flag(f, "late-s", 0);
  Peer p;
  if (late > 0) {
    // a long-lived node that makes its parameter clients late: it calls set_mode first (its
    // participant matched long before), then waits
    Client<capsule_msgs::srv::SetMode_Request, capsule_msgs::srv::SetMode_Response> c(
        p, "capsule_controller/set_mode", timeout);
    print_set_mode(c.call(set_mode_request(2, 0.1)));
    std::this_thread::sleep_for(std::chrono::duration<double>(late));
  }
  auto t0 = Clock::now();
  using namespace rcl_interfaces::srv;
  Client<ListParameters_Request, ListParameters_Response> list(p, node + "/list_parameters", timeout);
  Client<GetParameters_Request, GetParameters_Response> get(p, node + "/get_parameters", timeout);
  Client<SetParameters_Request, SetParameters_Response> set(p, node + "/set_parameters", timeout);
  auto names = list.call({}).result.names;
  if (names.empty()) fail("no parameters listed");
  GetParameters_Request gq;
  gq.names = names;
  auto values = get.call(gq).values;
  if (values.size() != names.size()) fail("get_parameters answered a different count");
  std::string out = "{\"names\": {";
  for (size_t i = 0; i < names.size(); i++)
    out += (i ? ", " : "") + json_str(names[i]) + ": " + value_json(values[i]);
  out += "}, \"set\": [";
  for (size_t i = 0; i < sets.size(); i++) {
    auto eq = sets[i].find('=');
    if (eq == std::string::npos) fail("--set NAME=DOUBLE");
    SetParameters_Request sq;
    rcl_interfaces::msg::Parameter prm;
    prm.name = sets[i].substr(0, eq);
    prm.value.type = 3;
    prm.value.double_value = std::strtod(sets[i].c_str() + eq + 1, nullptr);
    sq.parameters.push_back(prm);
    auto res = set.call(sq).results;
    if (res.size() != 1) fail("set_parameters answered " + std::to_string(res.size()) + " results");
    GetParameters_Request g1;
    g1.names = {prm.name};
    auto now = get.call(g1).values;
    out += std::string(i ? ", " : "") + "{\"name\": " + json_str(prm.name) + ", \"successful\": " +
           (res[0].successful ? "true" : "false") + ", \"reason\": " + json_str(res[0].reason) +
           ", \"now\": " + (now.size() == 1 ? value_json(now[0]) : "null") + "}";
  }
  out += "]";
  // with --late-s, how long the late clients took from their making to the last answer [s]
  if (late > 0)
    out += ", \"answered_s\": " + num(std::chrono::duration<double>(Clock::now() - t0).count());
  std::printf("%s}\n", out.c_str());
  return 0;
}

/// The SetMode request in rmw_cyclonedds's layout: a 16-byte header (client GUID half,
/// sequence number) before the fields, under the same DDS type name.
struct SetModeRequestCyclone {
  uint64_t client_guid = 0;
  int64_t sequence = 0;
  uint8_t mode = 0;
  double gain = 0;
  builtin_interfaces::msg::Time effective_from;
  int32_t pulse_periods = 0, target_period = 0, max_tries = 0;
  ROS_STRUCT(SetModeRequestCyclone, "capsule_msgs::srv::dds_::SetMode_Request_", client_guid,
             sequence, mode, gain, effective_from, pulse_periods, target_period, max_tries)
};

// --- bad: malformed identity, the other rmw's mapping, another layout; then a good call
static int cmd_bad(int argc, char** argv) {
  if (argc < 3) fail("bad KIND");
  std::string kind = argv[2];
  auto f = flags(argc, argv, 3);
  std::string service = f.count("service") ? f["service"] : "capsule_controller/set_mode";
  double timeout = flag(f, "timeout", 20);
  if (kind == "identity") {
    // a request whose related sample identity names no reader and an impossible sequence
    Peer p;
    Client<capsule_msgs::srv::SetMode_Request, capsule_msgs::srv::SetMode_Response> c(
        p, service, timeout);
    WriteParams wp;
    eprosima::fastrtps::rtps::SampleIdentity bogus;
    bogus.writer_guid(GUID_t::unknown());
    bogus.sequence_number(eprosima::fastrtps::rtps::SequenceNumber_t(-1, 0));
    wp.related_sample_identity(bogus);
    std::string reply = c.write_raw(set_mode_request(1, 0.2), wp, 2.0);
    std::printf("{\"bad\": \"identity\", \"reply\": \"%s\"}\n", reply.c_str());
    print_set_mode(c.call(set_mode_request(2, 0.1)));
  } else if (kind == "cyclone") {
    Peer p;
    DataWriter* w = p.writer<SetModeRequestCyclone>(
        "rq/" + service + "Request");
    wait_matched(w, timeout, "rq/" + service + "Request");
    SetModeRequestCyclone q;
    q.client_guid = 0x1234;
    q.sequence = 1;
    q.mode = 2;
    q.gain = 0.1;
    for (int i = 0; i < 5; i++) {
      w->write(&q);
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    std::printf("{\"bad\": \"cyclone\", \"sent\": 5}\n");
  } else if (kind == "layout") {
    Peer p;
    DataWriter* w = p.writer<capsule_msgs::msg::ActuatorForceOtherLayout>(
        "rt/capsule/actuator_force");
    wait_matched(w, timeout, "rt/capsule/actuator_force");
    capsule_msgs::msg::ActuatorForceOtherLayout q;
    q.note = "not an ActuatorForce";
    q.force = 7.0;
    for (int i = 0; i < 20; i++) {
      w->write(&q);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::printf("{\"bad\": \"layout\", \"sent\": 20}\n");
  } else {
    fail("unknown bad input kind " + kind);
  }
  return 0;
}

// --- lifecycle: a managed node's transitions by label, the state after each
static int cmd_lifecycle(int argc, char** argv) {
  std::vector<std::string> labels;
  int i = 2;
  for (; i < argc && std::strncmp(argv[i], "--", 2) != 0; i++) labels.push_back(argv[i]);
  auto f = flags(argc, argv, i);
  std::string node = f.count("node") ? f["node"] : "capsule_plant";
  double timeout = flag(f, "timeout", 20);
  Peer p;
  Client<lifecycle_msgs::srv::ChangeState_Request, lifecycle_msgs::srv::ChangeState_Response>
      change(p, node + "/change_state", timeout);
  Client<lifecycle_msgs::srv::GetState_Request, lifecycle_msgs::srv::GetState_Response> get(
      p, node + "/get_state", timeout);
  std::string out = "{\"lifecycle\": [";
  for (size_t k = 0; k < labels.size(); k++) {
    lifecycle_msgs::srv::ChangeState_Request q;
    q.transition.label = labels[k];
    bool ok = change.call(q).success;
    auto st = get.call({}).current_state;
    out += std::string(k ? ", " : "") + "{\"transition\": " + json_str(labels[k]) +
           ", \"success\": " + (ok ? "true" : "false") + ", \"state\": " + json_str(st.label) +
           ", \"id\": " + std::to_string(st.id) + "}";
  }
  std::printf("%s]}\n", out.c_str());
  return 0;
}

// --- estop: the plant's emergency stop (std_srvs/SetBool), the answer timed
static int cmd_estop(int argc, char** argv) {
  auto f = flags(argc, argv, 2);
  std::string service = f.count("service") ? f["service"] : "capsule_plant/emergency_stop";
  Peer p;
  Client<std_srvs::srv::SetBool_Request, std_srvs::srv::SetBool_Response> c(
      p, service, flag(f, "timeout", 20));
  std_srvs::srv::SetBool_Request q;
  q.data = true;
  auto t0 = Clock::now();
  auto r = c.call(q);
  double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  q.data = false;
  auto released = c.call(q);
  std::printf("{\"engaged\": %s, \"message\": %s, \"answer_ms\": %s, \"released\": %s}\n",
              r.success ? "true" : "false", json_str(r.message).c_str(), num(ms).c_str(),
              released.success ? "true" : "false");
  return 0;
}

// --- move: a Move goal as an rclcpp ActionClient on rmw_fastrtps sends it (send_goal, then
// get_result, the feedback read meanwhile); one JSON line
static int cmd_move(int argc, char** argv) {
  if (argc < 3) fail("move DISTANCE_M [--action A] [--timeout S]");
  double distance = std::strtod(argv[2], nullptr);
  auto f = flags(argc, argv, 3);
  std::string action = f.count("action") ? f["action"] : "capsule_controller/move";
  double timeout = flag(f, "timeout", 60);
  using namespace capsule_msgs::action;
  Peer p;
  DataReader* fb = p.reader<Move_FeedbackMessage>("rt/" + action + "/_action/feedback", 1000);
  Client<Move_SendGoal_Request, Move_SendGoal_Response> send(p, action + "/_action/send_goal",
                                                             timeout);
  Client<Move_GetResult_Request, Move_GetResult_Response> result(
      p, action + "/_action/get_result", timeout);
  Move_SendGoal_Request q;
  auto seed = static_cast<uint64_t>(Clock::now().time_since_epoch().count());
  for (int i = 0; i < 16; i++) q.goal_id.uuid[i] = static_cast<uint8_t>(seed >> (8 * (i % 8)) ^ i);
  q.goal.distance_m = distance;
  auto accepted = send.call(q);
  if (!accepted.accepted) {
    std::printf("{\"distance\": %s, \"accepted\": false}\n", num(distance).c_str());
    return 0;
  }
  Move_GetResult_Request g;
  g.goal_id = q.goal_id;
  auto r = result.call(g);
  int feedback = 0;
  for (const auto& m : take_all<Move_FeedbackMessage>(fb)) feedback += m.goal_id.uuid == q.goal_id.uuid;
  std::printf(
      "{\"distance\": %s, \"accepted\": true, \"status\": %d, \"reached\": %s, "
      "\"travelled_m\": %s, \"error_m\": %s, \"feedback\": %d}\n",
      num(distance).c_str(), r.status, r.result.reached ? "true" : "false",
      num(r.result.travelled_m).c_str(), num(r.result.error_m).c_str(), feedback);
  return 0;
}

int main(int argc, char** argv) {
  if (argc < 2) fail("usage: fastdds_peer state|force|set-mode|params|bad|lifecycle|estop ...");
  std::string cmd = argv[1];
  if (cmd == "state") return cmd_state(argc, argv);
  if (cmd == "force") return cmd_force(argc, argv);
  if (cmd == "set-mode") return cmd_set_mode(argc, argv);
  if (cmd == "params") return cmd_params(argc, argv);
  if (cmd == "bad") return cmd_bad(argc, argv);
  if (cmd == "lifecycle") return cmd_lifecycle(argc, argv);
  if (cmd == "estop") return cmd_estop(argc, argv);
  if (cmd == "move") return cmd_move(argc, argv);
  fail("unknown command " + cmd);
}
