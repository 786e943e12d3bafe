// The ROS 2 types the Fast DDS peer uses, laid out as rosidl generates them for rmw_fastrtps_cpp:
// C++ structs in the namespace pkg::msg / pkg::srv, DDS type names pkg::msg::dds_::Name_, plain
// XCDR1 (fastcdr 1.0, little endian, DDS_CDR encapsulation), fields in the order of the .msg
// file. The capsule_msgs fields follow capsule_msgs/msg/*.msg and srv/*.srv; the standard types
// follow the ROS 2 distribution's builtin_interfaces and rcl_interfaces.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>
#include <fastdds/dds/topic/TopicDataType.hpp>

using eprosima::fastcdr::Cdr;

// --- field serialisation, as rosidl's C++ type support for rmw_fastrtps writes it: primitives
// as fastcdr writes them, nested structs field by field, sequences as a uint32 length then the
// elements. Everything is declared before use (the types live in the global namespace).
#define PRIMITIVE(T) \
  inline void put(Cdr& c, const T& v) { c << v; } \
  inline void get(Cdr& c, T& v) { c >> v; }
PRIMITIVE(bool)
PRIMITIVE(int8_t)
PRIMITIVE(uint8_t)
PRIMITIVE(int32_t)
PRIMITIVE(uint32_t)
PRIMITIVE(int64_t)
PRIMITIVE(uint64_t)
PRIMITIVE(double)
PRIMITIVE(std::string)
#undef PRIMITIVE

// a fixed array (uint8[16]): its elements, no length
inline void put(Cdr& c, const std::array<uint8_t, 16>& v) { for (auto b : v) c << b; }
inline void get(Cdr& c, std::array<uint8_t, 16>& v) { for (auto& b : v) c >> b; }

template <class T>
auto put(Cdr& c, const T& v) -> decltype(v.ser(c)) { v.ser(c); }
template <class T>
auto get(Cdr& c, T& v) -> decltype(v.de(c)) { v.de(c); }

constexpr uint32_t kMaxSequence = 1u << 20;

template <class T>
void put(Cdr& c, const std::vector<T>& v) {
  c << static_cast<uint32_t>(v.size());
  for (const auto& e : v) put(c, static_cast<const T&>(e));
}
template <class T>
void get(Cdr& c, std::vector<T>& v) {
  uint32_t n = 0;
  c >> n;
  if (n > kMaxSequence) throw eprosima::fastcdr::exception::NotEnoughMemoryException("sequence");
  v.resize(n);
  for (uint32_t i = 0; i < n; i++) {
    T e{};
    get(c, e);
    v[i] = e;
  }
}

template <class... F>
void fields_put_impl(Cdr& c, const F&... f) { (put(c, f), ...); }
template <class... F>
void fields_get_impl(Cdr& c, F&... f) { (get(c, f), ...); }

// One struct's DDS type name and its fields in order, serialised one after the other.
#define ROS_STRUCT(NAME, DDS, ...)                                     \
  static const char* dds_name() { return DDS; }                        \
  void ser(Cdr& c) const { fields_put_impl(c, __VA_ARGS__); }          \
  void de(Cdr& c) { fields_get_impl(c, __VA_ARGS__); }

namespace builtin_interfaces::msg {
struct Time {
  int32_t sec = 0;
  uint32_t nanosec = 0;
  ROS_STRUCT(Time, "builtin_interfaces::msg::dds_::Time_", sec, nanosec)
};
}  // namespace builtin_interfaces::msg

namespace std_msgs::msg {
struct Header {
  builtin_interfaces::msg::Time stamp;
  std::string frame_id;
  ROS_STRUCT(Header, "std_msgs::msg::dds_::Header_", stamp, frame_id)
};
}  // namespace std_msgs::msg

namespace capsule_msgs::msg {
struct CapsuleState {
  std_msgs::msg::Header header;
  uint64_t seq = 0;
  double mass_position = 0, mass_velocity = 0, capsule_position = 0, capsule_velocity = 0;
  bool in_contact = false, stuck = false;
  double friction_force = 0, contact_force = 0, actuator_force = 0;
  bool command_stale = false;
  uint32_t rejected_commands = 0;
  ROS_STRUCT(CapsuleState, "capsule_msgs::msg::dds_::CapsuleState_", header, seq, mass_position,
             mass_velocity, capsule_position, capsule_velocity, in_contact, stuck,
             friction_force, contact_force, actuator_force, command_stale, rejected_commands)
};
struct ActuatorForce {
  std_msgs::msg::Header header;
  uint64_t state_seq = 0;
  double force = 0;
  ROS_STRUCT(ActuatorForce, "capsule_msgs::msg::dds_::ActuatorForce_", header, state_seq, force)
};
/// The ActuatorForce name with another layout (bad input: a type of the same name).
struct ActuatorForceOtherLayout {
  std::string note;
  double force = 0;
  ROS_STRUCT(ActuatorForceOtherLayout, "capsule_msgs::msg::dds_::ActuatorForce_", note, force)
};
}  // namespace capsule_msgs::msg

namespace capsule_msgs::srv {
struct SetMode_Request {
  uint8_t mode = 0;
  double gain = 0;
  builtin_interfaces::msg::Time effective_from;
  int32_t pulse_periods = 0, target_period = 0, max_tries = 0;
  ROS_STRUCT(SetMode_Request, "capsule_msgs::srv::dds_::SetMode_Request_", mode, gain,
             effective_from, pulse_periods, target_period, max_tries)
};
struct SetMode_Response {
  bool accepted = false;
  uint8_t mode = 0;
  double gain = 0;
  std::string reason;
  ROS_STRUCT(SetMode_Response, "capsule_msgs::srv::dds_::SetMode_Response_", accepted, mode, gain,
             reason)
};
}  // namespace capsule_msgs::srv

namespace rcl_interfaces::msg {
struct ParameterValue {
  uint8_t type = 0;
  bool bool_value = false;
  int64_t integer_value = 0;
  double double_value = 0;
  std::string string_value;
  std::vector<uint8_t> byte_array_value;
  std::vector<bool> bool_array_value;
  std::vector<int64_t> integer_array_value;
  std::vector<double> double_array_value;
  std::vector<std::string> string_array_value;
  ROS_STRUCT(ParameterValue, "rcl_interfaces::msg::dds_::ParameterValue_", type, bool_value,
             integer_value, double_value, string_value, byte_array_value, bool_array_value,
             integer_array_value, double_array_value, string_array_value)
};
}  // namespace rcl_interfaces::msg

namespace rcl_interfaces::msg {
struct Parameter {
  std::string name;
  ParameterValue value;
  ROS_STRUCT(Parameter, "rcl_interfaces::msg::dds_::Parameter_", name, value)
};
struct SetParametersResult {
  bool successful = false;
  std::string reason;
  ROS_STRUCT(SetParametersResult, "rcl_interfaces::msg::dds_::SetParametersResult_", successful,
             reason)
};
struct ListParametersResult {
  std::vector<std::string> names, prefixes;
  ROS_STRUCT(ListParametersResult, "rcl_interfaces::msg::dds_::ListParametersResult_", names,
             prefixes)
};
}  // namespace rcl_interfaces::msg

namespace rcl_interfaces::srv {
struct GetParameters_Request {
  std::vector<std::string> names;
  ROS_STRUCT(GetParameters_Request, "rcl_interfaces::srv::dds_::GetParameters_Request_", names)
};
struct GetParameters_Response {
  std::vector<rcl_interfaces::msg::ParameterValue> values;
  ROS_STRUCT(GetParameters_Response, "rcl_interfaces::srv::dds_::GetParameters_Response_", values)
};
struct SetParameters_Request {
  std::vector<rcl_interfaces::msg::Parameter> parameters;
  ROS_STRUCT(SetParameters_Request, "rcl_interfaces::srv::dds_::SetParameters_Request_",
             parameters)
};
struct SetParameters_Response {
  std::vector<rcl_interfaces::msg::SetParametersResult> results;
  ROS_STRUCT(SetParameters_Response, "rcl_interfaces::srv::dds_::SetParameters_Response_",
             results)
};
struct ListParameters_Request {
  std::vector<std::string> prefixes;
  uint64_t depth = 0;
  ROS_STRUCT(ListParameters_Request, "rcl_interfaces::srv::dds_::ListParameters_Request_",
             prefixes, depth)
};
struct ListParameters_Response {
  rcl_interfaces::msg::ListParametersResult result;
  ROS_STRUCT(ListParameters_Response, "rcl_interfaces::srv::dds_::ListParameters_Response_",
             result)
};
}  // namespace rcl_interfaces::srv

namespace lifecycle_msgs::msg {
struct State {
  uint8_t id = 0;
  std::string label;
  ROS_STRUCT(State, "lifecycle_msgs::msg::dds_::State_", id, label)
};
/// The same fields as State (id, label) under its own DDS name.
struct Transition : State {
  static const char* dds_name() { return "lifecycle_msgs::msg::dds_::Transition_"; }
};
}  // namespace lifecycle_msgs::msg

namespace lifecycle_msgs::srv {
struct ChangeState_Request {
  lifecycle_msgs::msg::Transition transition;
  ROS_STRUCT(ChangeState_Request, "lifecycle_msgs::srv::dds_::ChangeState_Request_", transition)
};
struct ChangeState_Response {
  bool success = false;
  ROS_STRUCT(ChangeState_Response, "lifecycle_msgs::srv::dds_::ChangeState_Response_", success)
};
/// An empty request: rosidl's one placeholder byte.
struct GetState_Request {
  uint8_t structure_needs_at_least_one_member = 0;
  ROS_STRUCT(GetState_Request, "lifecycle_msgs::srv::dds_::GetState_Request_",
             structure_needs_at_least_one_member)
};
struct GetState_Response {
  lifecycle_msgs::msg::State current_state;
  ROS_STRUCT(GetState_Response, "lifecycle_msgs::srv::dds_::GetState_Response_", current_state)
};
}  // namespace lifecycle_msgs::srv

namespace std_srvs::srv {
struct SetBool_Request {
  bool data = false;
  ROS_STRUCT(SetBool_Request, "std_srvs::srv::dds_::SetBool_Request_", data)
};
struct SetBool_Response {
  bool success = false;
  std::string message;
  ROS_STRUCT(SetBool_Response, "std_srvs::srv::dds_::SetBool_Response_", success, message)
};
}  // namespace std_srvs::srv

namespace unique_identifier_msgs::msg {
struct UUID {
  std::array<uint8_t, 16> uuid{};
  ROS_STRUCT(UUID, "unique_identifier_msgs::msg::dds_::UUID_", uuid)
};
}  // namespace unique_identifier_msgs::msg

// capsule_msgs/action/Move and the types rosidl derives from it (action/Move.action)
namespace capsule_msgs::action {
struct Move_Goal {
  double distance_m = 0, tolerance_m = 0, timeout_s = 0;
  ROS_STRUCT(Move_Goal, "capsule_msgs::action::dds_::Move_Goal_", distance_m, tolerance_m,
             timeout_s)
};
struct Move_Result {
  bool reached = false;
  double travelled_m = 0, error_m = 0, elapsed_s = 0;
  std::string message;
  ROS_STRUCT(Move_Result, "capsule_msgs::action::dds_::Move_Result_", reached, travelled_m,
             error_m, elapsed_s, message)
};
struct Move_Feedback {
  double travelled_m = 0, remaining_m = 0, speed_m_per_s = 0;
  uint8_t mode = 0;
  ROS_STRUCT(Move_Feedback, "capsule_msgs::action::dds_::Move_Feedback_", travelled_m,
             remaining_m, speed_m_per_s, mode)
};
struct Move_SendGoal_Request {
  unique_identifier_msgs::msg::UUID goal_id;
  Move_Goal goal;
  ROS_STRUCT(Move_SendGoal_Request, "capsule_msgs::action::dds_::Move_SendGoal_Request_", goal_id,
             goal)
};
struct Move_SendGoal_Response {
  bool accepted = false;
  builtin_interfaces::msg::Time stamp;
  ROS_STRUCT(Move_SendGoal_Response, "capsule_msgs::action::dds_::Move_SendGoal_Response_",
             accepted, stamp)
};
struct Move_GetResult_Request {
  unique_identifier_msgs::msg::UUID goal_id;
  ROS_STRUCT(Move_GetResult_Request, "capsule_msgs::action::dds_::Move_GetResult_Request_",
             goal_id)
};
struct Move_GetResult_Response {
  int8_t status = 0;
  Move_Result result;
  ROS_STRUCT(Move_GetResult_Response, "capsule_msgs::action::dds_::Move_GetResult_Response_",
             status, result)
};
struct Move_FeedbackMessage {
  unique_identifier_msgs::msg::UUID goal_id;
  Move_Feedback feedback;
  ROS_STRUCT(Move_FeedbackMessage, "capsule_msgs::action::dds_::Move_FeedbackMessage_", goal_id,
             feedback)
};
}  // namespace capsule_msgs::action

/// Fast DDS type support for one of the structs above: XCDR1, little endian, as rmw_fastrtps.
template <class T>
class RosType : public eprosima::fastdds::dds::TopicDataType {
 public:
  RosType() {
    setName(T::dds_name());
    m_typeSize = 4 + kMax;
    m_isGetKeyDefined = false;
  }
  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* p) override {
    eprosima::fastcdr::FastBuffer fb(reinterpret_cast<char*>(p->data), p->max_size);
    Cdr c(fb, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
    p->encapsulation = c.endianness() == Cdr::BIG_ENDIANNESS ? CDR_BE : CDR_LE;
    try {
      c.serialize_encapsulation();
      static_cast<T*>(data)->ser(c);
    } catch (eprosima::fastcdr::exception::Exception&) {
      return false;
    }
    p->length = static_cast<uint32_t>(c.getSerializedDataLength());
    return true;
  }
  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* p, void* data) override {
    eprosima::fastcdr::FastBuffer fb(reinterpret_cast<char*>(p->data), p->length);
    Cdr c(fb, Cdr::DEFAULT_ENDIAN, Cdr::DDS_CDR);
    try {
      c.read_encapsulation();
      static_cast<T*>(data)->de(c);
    } catch (eprosima::fastcdr::exception::Exception&) {
      return false;
    }
    return true;
  }
  std::function<uint32_t()> getSerializedSizeProvider(void*) override {
    return [] { return 4 + kMax; };
  }
  void* createData() override { return new T(); }
  void deleteData(void* d) override { delete static_cast<T*>(d); }
  bool getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) override { return false; }

 private:
  static constexpr uint32_t kMax = 64 * 1024;
};
