//! ROS 2 security (SROS2 enclaves) as rcl reads its conventions, on RustDDS's DDS Security
//! builtin plugins (authentication PKI-DH, access control, AES-GCM-GMAC).
//!
//! - security only when `ROS_SECURITY_ENABLE` is exactly `true`;
//! - the enclave is `ROS_SECURITY_ENCLAVE_OVERRIDE` if set, else `--enclave` (`--ros-args -e`),
//!   else `/`; its directory is `$ROS_SECURITY_KEYSTORE/enclaves/<enclave without its leading />`
//!   and holds SROS2's six files ([`ENCLAVE_FILES`]);
//! - `ROS_SECURITY_STRATEGY=Enforce`: a node whose enclave files are missing or refused by the
//!   plugins does not start, and the error names the file; any other strategy: the node starts
//!   unsecured and says so (a warning).
//!
//! [`Security::resolve`] checks the variables and the files before any work starts ([`diagnose`]:
//! the checks DDS Security makes of its own files, so `--check` names a bad one); the
//! participant is built secured in [`crate::ros_options::RosOptions::context`], where RustDDS has the
//! last word.

use std::path::{Path, PathBuf};

use crate::error::{bail, Result};

/// The files of an SROS2 enclave, under the names rmw_dds_common (and RustDDS) read.
pub const ENCLAVE_FILES: [&str; 6] = [
    "identity_ca.cert.pem",
    "cert.pem",
    "key.pem",
    "permissions_ca.cert.pem",
    "governance.p7s",
    "permissions.p7s",
];

/// SROS2's environment variables, read as rcl reads them (so tests can pass their own).
#[derive(Debug, Clone, Default)]
pub struct SecurityEnv {
    /// `ROS_SECURITY_ENABLE` is exactly `true`.
    pub enable: bool,
    /// `ROS_SECURITY_STRATEGY` is exactly `Enforce` (anything else is permissive).
    pub enforce: bool,
    /// `ROS_SECURITY_KEYSTORE`.
    pub keystore: Option<PathBuf>,
    /// `ROS_SECURITY_ENCLAVE_OVERRIDE` (wins over `--enclave`).
    pub enclave_override: Option<String>,
}

impl SecurityEnv {
    /// Reads the process environment.
    pub fn from_process() -> Self {
        Self::from_vars(|k| std::env::var(k).ok())
    }

    /// Reads the variables through `get` (unset or empty: not set).
    pub fn from_vars(get: impl Fn(&str) -> Option<String>) -> Self {
        let get = |k| get(k).filter(|v: &String| !v.is_empty());
        SecurityEnv {
            enable: get("ROS_SECURITY_ENABLE").as_deref() == Some("true"),
            enforce: get("ROS_SECURITY_STRATEGY").as_deref() == Some("Enforce"),
            keystore: get("ROS_SECURITY_KEYSTORE").map(PathBuf::from),
            enclave_override: get("ROS_SECURITY_ENCLAVE_OVERRIDE"),
        }
    }
}

/// How a node runs, as far as DDS Security goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Security {
    /// `ROS_SECURITY_ENABLE` is not `true`: no security, as stock ROS 2.
    Off,
    /// Secured with the enclave `name`, whose files are in `dir`.
    Enclave {
        /// The enclave's name (`/capsule/plant`).
        name: String,
        /// Its directory in the keystore.
        dir: PathBuf,
        /// `ROS_SECURITY_STRATEGY=Enforce`: a refusal by the plugins stops the node.
        enforce: bool,
    },
    /// Security was asked for, but the enclave cannot be used and the strategy is permissive:
    /// the node runs unsecured; `why` says what is missing.
    Unsecured {
        /// What is missing (names the variable or the file).
        why: String,
    },
}

impl Security {
    /// rcl's rules over `env` and the node's `--enclave`; under `Enforce` a missing keystore,
    /// enclave directory or file, or a file [`diagnose`] finds DDS Security would refuse, is an
    /// error naming it.
    pub fn resolve(env: &SecurityEnv, enclave_arg: Option<&str>) -> Result<Self> {
        if !env.enable {
            return Ok(Security::Off);
        }
        let enforce = env.enforce;
        let (name, origin) = match (&env.enclave_override, enclave_arg) {
            (Some(o), _) => (o.as_str(), "ROS_SECURITY_ENCLAVE_OVERRIDE"),
            (None, Some(e)) => (e, "--enclave"),
            (None, None) => ("/", "the default enclave"),
        };
        check_enclave_name(name)
            .map_err(|why| crate::error::invalid!("{origin} {name:?}: {why}"))?;
        let found = match &env.keystore {
            None => {
                Err("ROS_SECURITY_ENABLE=true but ROS_SECURITY_KEYSTORE is not set".to_string())
            }
            Some(k) => enclave_dir(k, name),
        };
        // files present: would DDS Security take them? (a refusal named here, before any work)
        let found = found.and_then(|dir| match diagnose(&dir) {
            Some(why) => Err(why),
            None => Ok(dir),
        });
        match found {
            Ok(dir) => Ok(Security::Enclave {
                name: name.to_string(),
                dir,
                enforce,
            }),
            Err(why) if enforce => bail!("ROS_SECURITY_STRATEGY=Enforce: enclave {name}: {why}"),
            Err(why) => Ok(Security::Unsecured {
                why: format!("enclave {name}: {why}"),
            }),
        }
    }

    /// A few words for the log and `--check`: `secured (enclave /capsule/plant)`, `unsecured`.
    pub fn describe(&self) -> String {
        match self {
            Security::Off => "unsecured".into(),
            Security::Enclave { name, enforce, .. } => format!(
                "secured (enclave {name}{})",
                if *enforce { ", Enforce" } else { "" }
            ),
            Security::Unsecured { why } => format!("UNSECURED ({why})"),
        }
    }
}

/// An enclave name as rcl takes it: absolute, `/` or `/a/b` with ROS name characters.
fn check_enclave_name(name: &str) -> Result<(), String> {
    if !name.starts_with('/') {
        return Err("an enclave name is absolute (starts with /)".into());
    }
    if name != "/" && name.ends_with('/') {
        return Err("an enclave name does not end with /".into());
    }
    if name.contains("//") {
        return Err("an enclave name has no empty part (//)".into());
    }
    if let Some(c) = name
        .chars()
        .find(|c| !(c.is_ascii_alphanumeric() || *c == '_' || *c == '/'))
    {
        return Err(format!("{c:?} is not allowed (letters, digits, _ and /)"));
    }
    Ok(())
}

/// The directory of enclave `name` in `keystore`, with every file of [`ENCLAVE_FILES`] in it;
/// else what is missing, naming it.
fn enclave_dir(keystore: &Path, name: &str) -> Result<PathBuf, String> {
    let dir = keystore.join("enclaves").join(name.trim_start_matches('/'));
    if !dir.is_dir() {
        return Err(format!(
            "no directory {} (ROS_SECURITY_KEYSTORE={})",
            dir.display(),
            keystore.display()
        ));
    }
    for f in ENCLAVE_FILES {
        let p = dir.join(f);
        match std::fs::metadata(&p) {
            Ok(m) if m.is_file() && m.len() > 0 => {}
            Ok(m) if m.is_file() => return Err(format!("{} is empty", p.display())),
            Ok(_) => return Err(format!("{} is not a file", p.display())),
            Err(e) => return Err(format!("cannot read {}: {e}", p.display())),
        }
    }
    Ok(dir)
}

/// `builder` with RustDDS's builtin plugins configured from the enclave directory `dir`.
#[cfg(feature = "security")]
pub(crate) fn configure(
    builder: rustdds::DomainParticipantBuilder,
    dir: &Path,
) -> Result<rustdds::DomainParticipantBuilder> {
    // SROS2's keys are unencrypted PKCS#8: RustDDS takes no password for them
    Ok(builder.builtin_security(
        rustdds::DomainParticipantSecurityConfigFiles::with_ros_default_names(dir, String::new()),
    ))
}

/// Without the `security` feature an enclave cannot be used: says so.
#[cfg(not(feature = "security"))]
pub(crate) fn configure(
    _builder: rustdds::DomainParticipantBuilder,
    dir: &Path,
) -> Result<rustdds::DomainParticipantBuilder> {
    bail!(
        "the enclave {}: this build has no DDS Security (capsule_ros_base's cargo feature `security`)",
        dir.display()
    )
}

/// Which file of the enclave in `dir` DDS Security would refuse, and why: the identity
/// certificate not signed by the identity CA or out of its validity, the key not a key or not
/// the certificate's, a signed document whose signature does not verify against the permissions
/// CA. `None` when each file passes these checks. Used to name the file after RustDDS refused
/// the enclave (its message names only the step).
#[cfg(feature = "security")]
pub fn diagnose(dir: &Path) -> Option<String> {
    use openssl::{
        asn1::Asn1Time,
        pkcs7::{Pkcs7, Pkcs7Flags},
        pkey::PKey,
        stack::Stack,
        x509::{store::X509StoreBuilder, X509},
    };
    let read = |f: &str| std::fs::read(dir.join(f)).map_err(|e| format!("{f}: {e}"));
    let cert =
        |f: &str| X509::from_pem(&read(f)?).map_err(|e| format!("{f}: not a PEM certificate: {e}"));
    let check = || -> Result<(), String> {
        let now = Asn1Time::days_from_now(0).map_err(|e| e.to_string())?;
        let identity_ca = cert("identity_ca.cert.pem")?;
        let own = cert("cert.pem")?;
        let signed = identity_ca
            .public_key()
            .and_then(|k| own.verify(&k))
            .unwrap_or(false);
        if !signed {
            return Err("cert.pem: not signed by identity_ca.cert.pem (another CA?)".into());
        }
        for (f, c) in [("identity_ca.cert.pem", &identity_ca), ("cert.pem", &own)] {
            if c.not_before() > now || c.not_after() < now {
                return Err(format!(
                    "{f}: not valid now (from {} to {})",
                    c.not_before(),
                    c.not_after()
                ));
            }
        }
        let key = PKey::private_key_from_pem(&read("key.pem")?)
            .map_err(|e| format!("key.pem: not an unencrypted PEM private key: {e}"))?;
        let matches = own.public_key().is_ok_and(|p| p.public_eq(&key));
        if !matches {
            return Err("key.pem: not the key of cert.pem".into());
        }
        let permissions_ca = cert("permissions_ca.cert.pem")?;
        for f in ["governance.p7s", "permissions.p7s"] {
            let (p7, content) = Pkcs7::from_smime(&read(f)?)
                .map_err(|e| format!("{f}: not an S/MIME signed document: {e}"))?;
            let mut store = X509StoreBuilder::new().map_err(|e| e.to_string())?;
            store
                .add_cert(permissions_ca.clone())
                .map_err(|e| e.to_string())?;
            let store = store.build();
            let certs = Stack::new().map_err(|e| e.to_string())?;
            p7.verify(
                &certs,
                &store,
                content.as_deref(),
                None,
                Pkcs7Flags::empty(),
            )
            .map_err(|_| {
                format!("{f}: its signature does not verify against permissions_ca.cert.pem")
            })?;
        }
        Ok(())
    };
    check().err()
}

/// Without the `security` feature no enclave reaches DDS: nothing to say.
#[cfg(not(feature = "security"))]
pub fn diagnose(_dir: &Path) -> Option<String> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(enable: &str, strategy: &str, keystore: Option<&Path>) -> SecurityEnv {
        SecurityEnv::from_vars(|k| match k {
            "ROS_SECURITY_ENABLE" => Some(enable.into()),
            "ROS_SECURITY_STRATEGY" => Some(strategy.into()),
            "ROS_SECURITY_KEYSTORE" => keystore.map(|k| k.display().to_string()),
            _ => None,
        })
    }

    /// The error `resolve` refuses with.
    fn refused(env: &SecurityEnv, enclave: Option<&str>) -> String {
        match Security::resolve(env, enclave) {
            Ok(s) => panic!("not refused: {s:?}"),
            Err(e) => e.to_string(),
        }
    }

    /// A keystore of placeholder files (present, not valid).
    fn keystore(tag: &str, enclaves: &[&str]) -> PathBuf {
        let k = std::env::temp_dir().join(format!("capsule_sec_{}_{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&k);
        for e in enclaves {
            let d = k.join("enclaves").join(e);
            std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("{e}"));
            for f in ENCLAVE_FILES {
                std::fs::write(d.join(f), "x").unwrap_or_else(|e| panic!("{e}"));
            }
        }
        k
    }

    #[test]
    fn only_exactly_true_enables_and_the_override_wins() -> Result<()> {
        // real files: resolve checks them as DDS Security would
        #[cfg(feature = "security")]
        let k = made_keystore("rules");
        #[cfg(not(feature = "security"))]
        let k = keystore("rules", &["capsule/plant", "capsule/operator"]);
        for not_true in ["1", "TRUE", "True", "yes", " true"] {
            assert_eq!(
                Security::resolve(&env(not_true, "Enforce", Some(&k)), Some("/capsule/plant"))?,
                Security::Off
            );
        }
        assert_eq!(
            Security::resolve(&SecurityEnv::default(), Some("/x"))?,
            Security::Off
        );
        let s = Security::resolve(&env("true", "Enforce", Some(&k)), Some("/capsule/plant"))?;
        assert_eq!(
            s,
            Security::Enclave {
                name: "/capsule/plant".into(),
                dir: k.join("enclaves/capsule/plant"),
                enforce: true
            }
        );
        let mut e = env("true", "Permissive", Some(&k));
        e.enclave_override = Some("/capsule/operator".into());
        let s = Security::resolve(&e, Some("/capsule/plant"))?;
        assert_eq!(
            s,
            Security::Enclave {
                name: "/capsule/operator".into(),
                dir: k.join("enclaves/capsule/operator"),
                enforce: false
            }
        );
        assert_eq!(s.describe(), "secured (enclave /capsule/operator)");
        let _ = std::fs::remove_dir_all(k);
        Ok(())
    }

    #[test]
    fn enforce_refuses_what_is_missing_and_names_it_permissive_runs_unsecured() -> Result<()> {
        let k = keystore("missing", &["capsule/plant"]);
        std::fs::remove_file(k.join("enclaves/capsule/plant/permissions.p7s"))
            .unwrap_or_else(|e| panic!("{e}"));
        let e = refused(&env("true", "Enforce", Some(&k)), Some("/capsule/plant"));
        assert!(
            e.contains("Enforce") && e.contains("capsule/plant/permissions.p7s"),
            "{e}"
        );
        let e = refused(&env("true", "Enforce", Some(&k)), Some("/capsule/nobody"));
        assert!(
            e.contains("no directory") && e.contains("capsule/nobody"),
            "{e}"
        );
        let e = refused(&env("true", "Enforce", None), None);
        assert!(e.contains("ROS_SECURITY_KEYSTORE is not set"), "{e}");
        #[cfg(feature = "security")]
        {
            let p = keystore("placeholders", &["capsule/plant"]);
            let e = refused(&env("true", "Enforce", Some(&p)), Some("/capsule/plant"));
            assert!(
                e.contains("identity_ca.cert.pem: not a PEM certificate"),
                "{e}"
            );
            let _ = std::fs::remove_dir_all(p);
        }
        let s = Security::resolve(&env("true", "Permissive", Some(&k)), Some("/capsule/plant"))?;
        match &s {
            Security::Unsecured { why } => assert!(why.contains("permissions.p7s"), "{why}"),
            other => panic!("{other:?}"),
        }
        assert!(s.describe().starts_with("UNSECURED"));
        for bad in ["capsule/plant", "/capsule/", "/a//b", "/a-b"] {
            let e = refused(&env("true", "Permissive", Some(&k)), Some(bad));
            assert!(e.contains(&format!("--enclave {bad:?}")), "{e}");
        }
        let _ = std::fs::remove_dir_all(k);
        Ok(())
    }

    /// A keystore made by launch_scripts/capsule_keystore.sh (needs the openssl command).
    #[cfg(feature = "security")]
    fn made_keystore(tag: &str) -> PathBuf {
        let k = std::env::temp_dir().join(format!("capsule_ks_{}_{tag}", std::process::id()));
        let _ = std::fs::remove_dir_all(&k);
        let script =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../launch_scripts/capsule_keystore.sh");
        let out = std::process::Command::new("bash")
            .arg(script)
            .arg("create")
            .arg(&k)
            .output()
            .unwrap_or_else(|e| panic!("cannot run capsule_keystore.sh: {e}"));
        assert!(
            out.status.success(),
            "capsule_keystore.sh (openssl installed? .ci/build-setup.sh): {}",
            String::from_utf8_lossy(&out.stderr)
        );
        k
    }

    #[cfg(feature = "security")]
    #[test]
    fn diagnose_names_the_file_dds_security_would_refuse() {
        let (k, other) = (made_keystore("a"), made_keystore("b"));
        let plant = k.join("enclaves/capsule/plant");
        assert_eq!(diagnose(&plant), None);
        assert_eq!(diagnose(&k.join("enclaves/capsule/operator")), None);
        let copy = |from: &Path, f: &str| {
            std::fs::copy(from.join(f), plant.join(f)).unwrap_or_else(|e| panic!("{e}"));
        };
        // the permissions text changed after signing
        let p = plant.join("permissions.p7s");
        let text = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{e}"));
        let tampered = text.replace("rt/capsule/state<", "rt/capsule/*<");
        assert_ne!(text, tampered);
        std::fs::write(&p, tampered).unwrap_or_else(|e| panic!("{e}"));
        let why = diagnose(&plant).unwrap_or_default();
        assert!(
            why.starts_with("permissions.p7s: its signature does not verify"),
            "{why}"
        );
        std::fs::write(&p, text).unwrap_or_else(|e| panic!("{e}"));
        // another CA's certificate, then another enclave's (not the key's)
        let own_cert = std::fs::read(plant.join("cert.pem")).unwrap_or_else(|e| panic!("{e}"));
        copy(&other.join("enclaves/capsule/plant"), "cert.pem");
        let why = diagnose(&plant).unwrap_or_default();
        assert!(
            why.starts_with("cert.pem: not signed by identity_ca.cert.pem"),
            "{why}"
        );
        copy(&k.join("enclaves/capsule/controller"), "cert.pem");
        let why = diagnose(&plant).unwrap_or_default();
        assert_eq!(why, "key.pem: not the key of cert.pem");
        std::fs::write(plant.join("cert.pem"), own_cert).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(diagnose(&plant), None);
        // a governance signed by another CA
        copy(&other.join("enclaves"), "governance.p7s");
        let why = diagnose(&plant).unwrap_or_default();
        assert!(
            why.starts_with("governance.p7s: its signature does not verify"),
            "{why}"
        );
        for d in [k, other] {
            let _ = std::fs::remove_dir_all(d);
        }
    }
}
