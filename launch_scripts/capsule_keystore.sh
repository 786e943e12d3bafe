#!/usr/bin/env bash
# An SROS2 keystore for the capsule graph, made with the system's openssl command (what
# `ros2 security create_keystore / create_enclave` do, step for step; nothing to build, every
# step readable here). docs/ros.md, Security.
#
#   launch_scripts/capsule_keystore.sh create KEYSTORE
#       the CA, the governance and one enclave per node of the graph: /capsule/plant,
#       /capsule/controller, /capsule/recorder, /capsule/foxglove, /capsule/replay and
#       /capsule/operator (capsule_ros, the ros2 CLI, an operator's tools)
#   launch_scripts/capsule_keystore.sh create_keystore KEYSTORE
#       the CA and the governance only (as `ros2 security create_keystore`)
#   launch_scripts/capsule_keystore.sh create_enclave KEYSTORE ENCLAVE ROLE
#       one more enclave, e.g. /lab/fastdds_peer operator (as `ros2 security create_enclave`,
#       with a role of launch_scripts/keystore/policy.txt as its permissions)
#   launch_scripts/capsule_keystore.sh roles
#       the roles of policy.txt
#
# Layout as SROS2's: KEYSTORE/public/{ca,identity_ca,permissions_ca}.cert.pem,
# KEYSTORE/private/ca.key.pem (keep it off the robot), KEYSTORE/enclaves/governance.{xml,p7s},
# KEYSTORE/enclaves/<enclave>/{identity_ca.cert.pem, cert.pem, key.pem, permissions_ca.cert.pem,
# governance.p7s, permissions.xml, permissions.p7s}. One CA signs identities and permissions
# (SROS2's default). Keys: ECDSA P-256, unencrypted PKCS#8 (DDS reads them unattended);
# certificates SHA-256, subject CN=<enclave>, valid VALID_DAYS (default 3650) from now; the
# governance (launch_scripts/keystore/governance.xml: SROS2's default) and each permissions
# document are S/MIME-signed by the CA in text mode, detached, as SROS2 signs them.
#
# Then run a node secured with ROS_SECURITY_KEYSTORE=KEYSTORE ROS_SECURITY_ENABLE=true
# ROS_SECURITY_STRATEGY=Enforce and `--ros-args --enclave /capsule/plant` (or
# launch_scripts/capsule_launch.sh --secure KEYSTORE).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
templates="$here/keystore"
policy="$templates/policy.txt"
valid_days="${VALID_DAYS:-3650}"
usage() { sed -n '2,29p' "$0" | sed 's/^# \{0,1\}//'; }
die() { echo "capsule_keystore: $*" >&2; exit 2; }
command -v openssl >/dev/null 2>&1 || die "openssl not found (Debian: apt-get install openssl)"
[[ "$valid_days" =~ ^[1-9][0-9]{0,5}$ ]] || die "VALID_DAYS '$valid_days': a whole number of days (1 to 999999)"

roles() { awk '!/^#/ && NF >= 2 { print $1 }' "$policy" | sort -u; }

create_keystore() { # KEYSTORE
  local ks="$1"
  if [ -e "$ks/private/ca.key.pem" ]; then die "$ks already holds a keystore (private/ca.key.pem): not overwritten"; fi
  mkdir -p "$ks/public" "$ks/private" "$ks/enclaves"
  chmod 700 "$ks/private"
  # the CA: ECDSA P-256, self-signed, SHA-256
  openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$ks/private/ca.key.pem" 2>/dev/null
  chmod 600 "$ks/private/ca.key.pem"
  openssl req -x509 -new -sha256 -key "$ks/private/ca.key.pem" -subj "/CN=capsule_keystore_CA" \
    -days "$valid_days" -addext "basicConstraints=critical,CA:TRUE" \
    -addext "keyUsage=critical,keyCertSign,cRLSign,digitalSignature" \
    -out "$ks/public/ca.cert.pem"
  cp "$ks/public/ca.cert.pem" "$ks/public/identity_ca.cert.pem"
  cp "$ks/public/ca.cert.pem" "$ks/public/permissions_ca.cert.pem"
  cp "$ks/private/ca.key.pem" "$ks/private/identity_ca.key.pem"
  cp "$ks/private/ca.key.pem" "$ks/private/permissions_ca.key.pem"
  chmod 600 "$ks/private/"*.pem
  cp "$templates/governance.xml" "$ks/enclaves/governance.xml"
  sign "$ks" "$ks/enclaves/governance.xml" "$ks/enclaves/governance.p7s"
  echo "capsule_keystore: keystore $ks (CA CN=capsule_keystore_CA, governance signed)"
}

sign() { # KEYSTORE IN OUT: S/MIME, text mode, detached, signed by the permissions CA
  openssl smime -sign -text -md sha256 -in "$2" -out "$3" \
    -signer "$1/public/permissions_ca.cert.pem" -inkey "$1/private/permissions_ca.key.pem"
}

xml_topics() { # ACCESS WORDS...: <ACCESS><topics>...</topics></ACCESS>, nothing if no words
  local access="$1"; shift
  [ $# -gt 0 ] || return 0
  printf '        <%s>\n          <topics>\n' "$access"
  for t in "$@"; do printf '            <topic>%s</topic>\n' "$t"; done
  printf '          </topics>\n        </%s>\n' "$access"
}

permissions_xml() { # ENCLAVE ROLE NOT_BEFORE NOT_AFTER
  local enclave="$1" role="$2" nb="$3" na="$4" node="" pub=() sub=()
  while read -r r what rest; do
    [ "$r" = "$role" ] || continue
    # shellcheck disable=SC2206
    case "$what" in
      node) node="$rest" ;;
      publish) pub+=($rest) ;;
      subscribe) sub+=($rest) ;;
      *) die "$policy: role $role: unknown rule '$what'" ;;
    esac
  done < <(grep -v '^#' "$policy")
  [ -n "$node" ] || die "$policy: role $role has no 'node' line"
  pub+=("rt/$node/*" "rr/$node/*" rt/rosout rt/parameter_events)
  sub+=("rq/$node/*" rt/parameter_events)
  cat <<XML
<?xml version="1.0" encoding="UTF-8"?>
<!-- enclave $enclave, role $role of launch_scripts/keystore/policy.txt -->
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="$enclave">
      <subject_name>CN=$enclave</subject_name>
      <validity>
        <not_before>$nb</not_before>
        <not_after>$na</not_after>
      </validity>
      <allow_rule>
        <domains>
          <id_range>
            <min>0</min>
            <max>232</max>
          </id_range>
        </domains>
$(xml_topics publish "${pub[@]}")
$(xml_topics subscribe "${sub[@]}")
      </allow_rule>
      <allow_rule>
        <domains>
          <id_range>
            <min>0</min>
            <max>232</max>
          </id_range>
        </domains>
$(xml_topics publish ros_discovery_info)
$(xml_topics subscribe ros_discovery_info)
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
XML
}

iso_date() { # an openssl date (notBefore=Nov 27 01:02:03 2026 GMT) as 2026-11-27T01:02:03
  date -u -d "${1#*=}" +%Y-%m-%dT%H:%M:%S
}

create_enclave() { # KEYSTORE ENCLAVE ROLE
  local ks="$1" enclave="$2" role="$3"
  [ -f "$ks/private/identity_ca.key.pem" ] || die "$ks: not a keystore (no private/identity_ca.key.pem): run create_keystore first"
  [[ "$enclave" =~ ^(/[A-Za-z0-9_]+)+$ ]] || die "enclave '$enclave': an absolute name such as /capsule/plant (letters, digits, _)"
  roles | grep -qx -- "$role" || die "role '$role': not in $policy (roles: $(roles | tr '\n' ' '))"
  local dir="$ks/enclaves/${enclave#/}"
  [ -e "$dir/key.pem" ] && die "$dir already holds an enclave: not overwritten"
  mkdir -p "$dir"
  openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$dir/key.pem" 2>/dev/null
  chmod 600 "$dir/key.pem"
  # subject CN=<enclave> (a / in a -subj value is escaped)
  openssl req -new -sha256 -key "$dir/key.pem" -subj "/CN=${enclave//\//\\/}" -out "$dir/req.pem"
  openssl x509 -req -sha256 -in "$dir/req.pem" -CA "$ks/public/identity_ca.cert.pem" \
    -CAkey "$ks/private/identity_ca.key.pem" -set_serial "0x$(openssl rand -hex 16)" \
    -days "$valid_days" -extfile <(printf 'basicConstraints=CA:FALSE\nkeyUsage=critical,digitalSignature,keyAgreement\n') \
    -out "$dir/cert.pem" 2>/dev/null
  rm -f "$dir/req.pem"
  cp "$ks/public/identity_ca.cert.pem" "$dir/identity_ca.cert.pem"
  cp "$ks/public/permissions_ca.cert.pem" "$dir/permissions_ca.cert.pem"
  cp "$ks/enclaves/governance.p7s" "$dir/governance.p7s"
  # the grant is valid exactly while the certificate is
  local nb na
  nb=$(iso_date "$(openssl x509 -in "$dir/cert.pem" -noout -startdate)")
  na=$(iso_date "$(openssl x509 -in "$dir/cert.pem" -noout -enddate)")
  permissions_xml "$enclave" "$role" "$nb" "$na" > "$dir/permissions.xml"
  sign "$ks" "$dir/permissions.xml" "$dir/permissions.p7s"
  echo "capsule_keystore: enclave $enclave (role $role) in $dir"
}

cmd="${1:-}"
case "$cmd" in
  -h|--help|"") usage; [ -n "$cmd" ]; exit ;;
  roles) roles; exit 0 ;;
  create|create_keystore)
    [ $# -eq 2 ] || die "$cmd KEYSTORE"
    create_keystore "$2"
    if [ "$cmd" = create ]; then
      for e in plant controller recorder foxglove replay operator; do create_enclave "$2" "/capsule/$e" "$e"; done
    fi ;;
  create_enclave)
    [ $# -eq 4 ] || die "create_enclave KEYSTORE ENCLAVE ROLE"
    create_enclave "$2" "$3" "$4" ;;
  *) usage >&2; die "unknown command '$cmd'" ;;
esac
