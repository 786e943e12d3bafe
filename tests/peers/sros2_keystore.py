#!/usr/bin/env python3
"""An SROS2 keystore made by the method of `ros2 security` (the sros2 package), which is not
installable here: Python's `cryptography` package, as sros2 uses it, written independently from
reading sros2 0.13 (keystore/_keystore.py, _enclave.py, _permission.py, _utilities.py and its
policy templates). tests/integration/ros/security.rs checks that the capsule nodes and the Fast
DDS peer run secured with it (docs/ros.md, Security).

  sros2_keystore.py create_keystore KEYSTORE
      as `ros2 security create_keystore`: one CA (CN=sros2CA) for identities and permissions,
      sros2's default governance for $ROS_DOMAIN_ID (default 0), signed
  sros2_keystore.py create_enclave KEYSTORE ENCLAVE
      as `ros2 security create_enclave`: a key and certificate (CN=ENCLAVE) and sros2's default
      permissions (its policy.xml: every topic, service and action in the domain), signed
  sros2_keystore.py create_permission KEYSTORE ENCLAVE POLICY
      as `ros2 security create_permission`: the enclave's permissions from POLICY (sros2's
      policy XML, version 0.2.0), signed
  sros2_keystore.py create KEYSTORE POLICY
      create_keystore, then create_enclave and create_permission for every enclave in POLICY

What sros2 does, and so this: ECDSA P-256 keys written as unencrypted PKCS#8 PEM; SHA-256
X.509 certificates with a random serial, valid from one day before now for 3650 days, the CA's
with a critical BasicConstraints CA:TRUE, pathlen 1, an enclave's with a non-critical CA:FALSE
(no key usage on either); public/{identity_ca,permissions_ca}.cert.pem and the matching
private/ keys are symbolic links to ca.cert.pem and ca.key.pem, and each enclave's CA
certificates and governance.p7s are relative links into public/ and enclaves/; the governance
and the permissions are S/MIME-signed by the CA in text mode, detached, SHA-256
(PKCS7SignatureBuilder with PKCS7Options.Text and DetachedSignature); the permissions' grant has
the subject CN=ENCLAVE and the certificate's validity, one allow (and deny) rule per grant for
the domain, and the separate ros_discovery_info rule sros2 adds for rmw_fastrtps_cpp (ROS 2's
default middleware). sros2 also checks the XML against its XSD schemas (with lxml); this
does not.
"""

import datetime
import os
import pathlib
import re
import sys
import xml.etree.ElementTree as ET

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.hazmat.primitives.serialization import pkcs7
from cryptography.x509.oid import NameOID

CA_NAME = "sros2CA"
VALID_DAYS = 3650
DDS_XSI = "http://www.w3.org/2001/XMLSchema-instance"
GOVERNANCE_XSD = "http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd"
PERMISSIONS_XSD = "http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd"

# sros2's default governance: authenticated participants only, join access control, encrypted
# discovery, liveliness and data, signed RTPS messages, every topic under access control
GOVERNANCE_RULES = [
    ("allow_unauthenticated_participants", "false"),
    ("enable_join_access_control", "true"),
    ("discovery_protection_kind", "ENCRYPT"),
    ("liveliness_protection_kind", "ENCRYPT"),
    ("rtps_protection_kind", "SIGN"),
]
GOVERNANCE_TOPIC_RULE = [
    ("topic_expression", "*"),
    ("enable_discovery_protection", "true"),
    ("enable_liveliness_protection", "true"),
    ("enable_read_access_control", "true"),
    ("enable_write_access_control", "true"),
    ("metadata_protection_kind", "ENCRYPT"),
    ("data_protection_kind", "ENCRYPT"),
]


class Refused(Exception):
    """Bad input: the message names it and why."""


def domain_id():
    d = os.environ.get("ROS_DOMAIN_ID", "0")
    if not d.isdigit() or int(d) > 232:
        raise Refused(f"ROS_DOMAIN_ID={d!r}: a domain id from 0 to 232")
    return str(int(d))


# --- keys, certificates, signatures -----------------------------------------------------------


def name(common_name):
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, common_name)])


def new_key_and_cert(subject, *, ca=False, issuer=None, issuer_key=None):
    """A P-256 key and its SHA-256 certificate: self-signed for the CA, else signed by
    issuer_key."""
    key = ec.generate_private_key(ec.SECP256R1())
    now = datetime.datetime.now(datetime.timezone.utc)
    constraints = x509.BasicConstraints(ca=True, path_length=1) if ca else x509.BasicConstraints(
        ca=False, path_length=None)
    cert = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(issuer if issuer is not None else subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        # a day back, as sros2 (some DDS vendors read a fresh date as in the future)
        .not_valid_before(now - datetime.timedelta(days=1))
        .not_valid_after(now + datetime.timedelta(days=VALID_DAYS))
        .add_extension(constraints, critical=ca)
        .sign(issuer_key if issuer_key is not None else key, hashes.SHA256())
    )
    return key, cert


def write_key(key, path):
    pem = key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                            serialization.NoEncryption())
    path.write_bytes(pem)
    path.chmod(0o600)


def write_cert(cert, path):
    path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))


def load_cert(path):
    return x509.load_pem_x509_certificate(path.read_bytes())


def load_key(path):
    return serialization.load_pem_private_key(path.read_bytes(), password=None)


def sign_smime(keystore, unsigned, signed):
    """`signed`: `unsigned`'s bytes S/MIME-signed by the permissions CA (text, detached)."""
    cert = load_cert(keystore / "public" / "permissions_ca.cert.pem")
    key = load_key(keystore / "private" / "permissions_ca.key.pem")
    smime = (
        pkcs7.PKCS7SignatureBuilder()
        .set_data(unsigned.read_bytes())
        .add_signer(cert, key, hashes.SHA256())
        .sign(serialization.Encoding.SMIME,
              [pkcs7.PKCS7Options.Text, pkcs7.PKCS7Options.DetachedSignature])
    )
    signed.write_bytes(smime)


def link(dst, target):
    """dst -> target (a relative path), replacing an older dst."""
    if dst.is_symlink() or dst.exists():
        dst.unlink()
    dst.symlink_to(target)


# --- XML ---------------------------------------------------------------------------------------


def sub(parent, tag, text=None):
    e = ET.SubElement(parent, tag)
    if text is not None:
        e.text = text
    return e


def dds_root(xsd):
    root = ET.Element("dds")
    root.set("xmlns:xsi", DDS_XSI)
    root.set("xsi:noNamespaceSchemaLocation", xsd)
    return root


def write_xml(root, path):
    ET.indent(root, space="  ")
    # as sros2 writes them (lxml's tostring): no XML declaration
    path.write_bytes(ET.tostring(root, encoding="utf-8", xml_declaration=False) + b"\n")


def governance_xml(domain):
    root = dds_root(GOVERNANCE_XSD)
    rule = sub(sub(root, "domain_access_rules"), "domain_rule")
    sub(sub(rule, "domains"), "id", domain)
    for tag, value in GOVERNANCE_RULES:
        sub(rule, tag, value)
    topic_rule = sub(sub(rule, "topic_access_rules"), "topic_rule")
    for tag, value in GOVERNANCE_TOPIC_RULE:
        sub(topic_rule, tag, value)
    return root


def default_policy(enclave):
    """sros2's default policy (policy/defaults/policy.xml) for one enclave: every topic,
    service and action of the domain, both ways."""
    policy = ET.Element("policy", version="0.2.0")
    e = sub(sub(policy, "enclaves"), "enclave")
    e.set("path", enclave)
    profile = sub(sub(e, "profiles"), "profile")
    profile.set("ns", "/")
    profile.set("node", "default")
    for group, item, attrs in (("topics", "topic", ("publish", "subscribe")),
                               ("services", "service", ("reply", "request")),
                               ("actions", "action", ("call", "execute"))):
        g = sub(profile, group)
        for a in attrs:
            g.set(a, "ALLOW")
        sub(g, item, "/*")
    return policy


def load_policy(path):
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as e:
        raise Refused(f"policy {path}: {e}") from e
    if root.tag != "policy" or root.get("version") != "0.2.0":
        raise Refused(f"policy {path}: not an sros2 policy (<policy version=\"0.2.0\">)")
    return root


def enclave_of(policy, enclave, where):
    for e in policy.findall("enclaves/enclave"):
        if e.get("path") == enclave:
            return e
    raise Refused(f"policy {where}: no <enclave path=\"{enclave}\">")


def resolve(expr, ns, node):
    """A policy name as a fully qualified ROS name: absolute as is, `~` the node's private
    namespace, else relative to the profile's namespace."""
    ns = ns if ns.endswith("/") else ns + "/"
    if expr.startswith("/"):
        return expr
    if expr.startswith("~"):
        return ns + node + expr[1:]
    return ns + expr


ACTION_TOPICS = {
    # (DDS name prefix, suffix) pairs the caller writes; it reads the others
    "call": (["rq{}/_action/cancel_goalRequest", "rq{}/_action/get_resultRequest",
              "rq{}/_action/send_goalRequest"],
             ["rr{}/_action/cancel_goalReply", "rr{}/_action/get_resultReply",
              "rr{}/_action/send_goalReply", "rt{}/_action/feedback", "rt{}/_action/status"]),
}
ACTION_TOPICS["execute"] = (ACTION_TOPICS["call"][1], ACTION_TOPICS["call"][0])


def dds_names(group, attr, fqn):
    """(publish, subscribe) DDS topic names that `attr`=... on a policy `group` grants for the
    ROS name `fqn` (ROS 2's mapping: topics rt/, requests rq/...Request, replies rr/...Reply)."""
    if group == "topics":
        return ([f"rt{fqn}"], []) if attr == "publish" else ([], [f"rt{fqn}"])
    if group == "services":
        req, rep = f"rq{fqn}Request", f"rr{fqn}Reply"
        return ([req], [rep]) if attr == "request" else ([rep], [req])
    pub, subs = ACTION_TOPICS[attr]
    return [p.format(fqn) for p in pub], [s.format(fqn) for s in subs]


GROUPS = {"topics": ("topic", ("publish", "subscribe")),
          "services": ("service", ("request", "reply")),
          "actions": ("action", ("call", "execute"))}


def rule_topics(profiles, qualifier, where):
    """The (publish, subscribe) DDS names of every profile in `profiles` with `qualifier`
    (ALLOW or DENY)."""
    pub, subs = [], []
    for profile in profiles.findall("profile"):
        ns, node = profile.get("ns"), profile.get("node")
        if ns is None or node is None:
            raise Refused(f"policy {where}: a <profile> without ns= or node=")
        for group in profile:
            if group.tag not in GROUPS:
                raise Refused(f"policy {where}: <{group.tag}> in a profile (topics, services, "
                              "actions)")
            item, attrs = GROUPS[group.tag]
            for a, q in group.attrib.items():
                if a not in attrs or q not in ("ALLOW", "DENY"):
                    raise Refused(f"policy {where}: <{group.tag} {a}=\"{q}\">")
            for a in attrs:
                if group.get(a) != qualifier:
                    continue
                for e in group.findall(item):
                    p, s = dds_names(group.tag, a, resolve((e.text or "").strip(), ns, node))
                    pub += p
                    subs += s
    return sorted(set(pub)), sorted(set(subs))


def add_rule(grant, tag, domain, pub, subs):
    rule = sub(grant, tag)
    sub(sub(rule, "domains"), "id", domain)
    for access, names in (("publish", pub), ("subscribe", subs)):
        if names:
            topics = sub(sub(rule, access), "topics")
            for n in names:
                sub(topics, "topic", n)


def permissions_xml(enclave_element, cert, domain, where):
    """The permissions of one policy enclave: a grant per <profiles>, valid while `cert` is."""
    path = enclave_element.get("path")
    root = dds_root(PERMISSIONS_XSD)
    perms = sub(root, "permissions")
    iso = lambda t: t.replace(tzinfo=None).isoformat()  # noqa: E731 (sros2's format)
    for profiles in enclave_element.findall("profiles"):
        grant = sub(perms, "grant")
        grant.set("name", path)
        sub(grant, "subject_name", f"CN={path}")
        validity = sub(grant, "validity")
        sub(validity, "not_before", iso(cert.not_valid_before_utc))
        sub(validity, "not_after", iso(cert.not_valid_after_utc))
        for qualifier, tag in (("DENY", "deny_rule"), ("ALLOW", "allow_rule")):
            pub, subs = rule_topics(profiles, qualifier, where)
            if pub or subs:
                add_rule(grant, tag, domain, pub, subs)
        add_rule(grant, "allow_rule", domain, ["ros_discovery_info"], ["ros_discovery_info"])
        sub(grant, "default", "DENY")
    return root


# --- the verbs ---------------------------------------------------------------------------------


def is_keystore(ks):
    return all((ks / p).is_file() for p in (
        "public/permissions_ca.cert.pem", "public/identity_ca.cert.pem",
        "private/permissions_ca.key.pem", "private/identity_ca.key.pem",
        "enclaves/governance.p7s"))


def create_keystore(ks):
    if is_keystore(ks):
        raise Refused(f"{ks} already holds a keystore: not overwritten")
    domain = domain_id()
    for d in ("public", "private", "enclaves"):
        (ks / d).mkdir(parents=True, exist_ok=True)
    (ks / "private").chmod(0o700)
    key, cert = new_key_and_cert(name(CA_NAME), ca=True)
    write_key(key, ks / "private" / "ca.key.pem")
    write_cert(cert, ks / "public" / "ca.cert.pem")
    for role in ("identity_ca", "permissions_ca"):
        link(ks / "public" / f"{role}.cert.pem", "ca.cert.pem")
        link(ks / "private" / f"{role}.key.pem", "ca.key.pem")
    gov = ks / "enclaves" / "governance.xml"
    write_xml(governance_xml(domain), gov)
    sign_smime(ks, gov, ks / "enclaves" / "governance.p7s")
    print(f"sros2_keystore: keystore {ks} (CA CN={CA_NAME}, governance for domain {domain})")


# a ROS namespace, as sros2 checks an enclave name: /, or /token(/token)* with tokens of
# letters, digits and _ not starting with a digit
ENCLAVE_NAME = re.compile(r"^/$|^(/[A-Za-z_][A-Za-z0-9_]*)+$")


def enclave_dir(ks, enclave):
    if not is_keystore(ks):
        raise Refused(f"{ks}: not a keystore (run create_keystore first)")
    if not ENCLAVE_NAME.match(enclave):
        raise Refused(f"enclave {enclave!r}: an absolute ROS namespace such as /capsule/plant")
    return ks / "enclaves" / enclave.lstrip("/")


def write_permissions(ks, enclave, policy, where):
    d = enclave_dir(ks, enclave)
    if not (d / "cert.pem").is_file():
        raise Refused(f"{d}: no cert.pem (run create_enclave first)")
    xml = permissions_xml(enclave_of(policy, enclave, where), load_cert(d / "cert.pem"),
                          domain_id(), where)
    write_xml(xml, d / "permissions.xml")
    sign_smime(ks, d / "permissions.xml", d / "permissions.p7s")


def create_enclave(ks, enclave):
    d = enclave_dir(ks, enclave)
    d.mkdir(parents=True, exist_ok=True)
    for f in ("identity_ca.cert.pem", "permissions_ca.cert.pem"):
        link(d / f, os.path.relpath(ks / "public" / f, d))
    link(d / "governance.p7s", os.path.relpath(ks / "enclaves" / "governance.p7s", d))
    if not ((d / "cert.pem").is_file() and (d / "key.pem").is_file()):
        ca = load_cert(ks / "public" / "identity_ca.cert.pem")
        key, cert = new_key_and_cert(name(enclave), issuer=ca.subject,
                                     issuer_key=load_key(ks / "private" / "identity_ca.key.pem"))
        write_key(key, d / "key.pem")
        write_cert(cert, d / "cert.pem")
    write_permissions(ks, enclave, default_policy(enclave), "(sros2's default)")
    print(f"sros2_keystore: enclave {enclave} in {d} (sros2's default permissions)")


def create_permission(ks, enclave, policy_path):
    write_permissions(ks, enclave, load_policy(policy_path), policy_path)
    print(f"sros2_keystore: enclave {enclave}: permissions from {policy_path}")


def create(ks, policy_path):
    policy = load_policy(policy_path)
    enclaves = [e.get("path") for e in policy.findall("enclaves/enclave")]
    if not enclaves or None in enclaves:
        raise Refused(f"policy {policy_path}: no <enclave path=...>")
    create_keystore(ks)
    for e in enclaves:
        create_enclave(ks, e)
        create_permission(ks, e, policy_path)


def main(argv):
    verbs = {"create_keystore": (create_keystore, 1), "create_enclave": (create_enclave, 2),
             "create_permission": (create_permission, 3), "create": (create, 2)}
    if len(argv) < 2 or argv[1] in ("-h", "--help"):
        print(__doc__)
        return 0 if len(argv) == 2 else 2
    verb = verbs.get(argv[1])
    if verb is None or len(argv) - 2 != verb[1]:
        print(f"sros2_keystore: usage: {argv[1]} takes {verb[1]} arguments (see --help)"
              if verb else f"sros2_keystore: unknown command {argv[1]!r} (see --help)",
              file=sys.stderr)
        return 2
    args = [pathlib.Path(argv[2])] + argv[3:]
    if argv[1] in ("create_permission", "create"):
        args[-1] = pathlib.Path(args[-1])
    try:
        verb[0](*args)
    except Refused as e:
        print(f"sros2_keystore: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
