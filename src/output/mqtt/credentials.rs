//! The broker's user name and password, from `[output.mqtt]
//! credentials_file`: never on the command line (every user of the
//! machine can read it in `/proc`) and never in a report or an error.

use std::fmt;
use std::os::unix::fs::PermissionsExt;
use std::path::Path;

use serde::Deserialize;

/// A user name and password for the broker. Its `Debug` hides the
/// password.
#[derive(Clone, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Credentials {
    /// The user name.
    pub username: String,
    /// The password.
    pub password: String,
}

impl fmt::Debug for Credentials {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Credentials")
            .field("username", &self.username)
            .field("password", &"…")
            .finish()
    }
}

impl Credentials {
    /// Reads `path`: TOML with `username = "…"` and `password = "…"`,
    /// refused if everyone may read it. The error names the file and the
    /// line, never what it holds.
    pub fn read(path: &Path) -> Result<Credentials, String> {
        let shown = path.display();
        let metadata =
            std::fs::metadata(path).map_err(|e| format!("credentials file {shown}: {e}"))?;
        let mode = metadata.permissions().mode();
        if mode & 0o004 != 0 {
            return Err(format!(
                "credentials file {shown} is readable by every user of this machine (mode {:03o}): \
                 make it its owner's only with `chmod 600 {shown}`",
                mode & 0o777
            ));
        }
        let text =
            std::fs::read_to_string(path).map_err(|e| format!("credentials file {shown}: {e}"))?;
        toml::from_str::<Credentials>(&text).map_err(|e| {
            let line = e
                .span()
                .filter(|span| span.start > 0)
                .map(|span| text.get(..span.start).unwrap_or("").lines().count().max(1));
            let at = line.map_or_else(String::new, |l| format!(" (line {l})"));
            // A key's name helps; a value (the password, perhaps) is never shown.
            let message = e.message();
            let about_a_key =
                message.starts_with("unknown field") || message.starts_with("missing field");
            let why = if about_a_key {
                format!(" ({message})")
            } else {
                String::new()
            };
            format!(
                "credentials file {shown}{at}: expected exactly two lines, \
                 `username = \"…\"` and `password = \"…\"`{why}"
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, text: &str, mode: u32) -> std::path::PathBuf {
        let path = dir.join("mqtt.toml");
        std::fs::write(&path, text).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode)).unwrap();
        path
    }

    #[test]
    fn owner_only_file_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(
            dir.path(),
            "username = \"ha\"\npassword = \"s3cret\"\n",
            0o600,
        );
        let c = Credentials::read(&path).unwrap();
        assert_eq!((c.username.as_str(), c.password.as_str()), ("ha", "s3cret"));
        assert!(!format!("{c:?}").contains("s3cret"));
    }

    #[test]
    fn world_readable_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(
            dir.path(),
            "username = \"ha\"\npassword = \"s3cret\"\n",
            0o644,
        );
        let e = Credentials::read(&path).unwrap_err();
        assert!(e.contains("readable by every user"), "{e}");
        assert!(e.contains("mode 644") && e.contains("chmod 600"), "{e}");
    }

    #[test]
    fn a_bad_file_is_named_without_its_content() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(
            dir.path(),
            "username = \"ha\"\npasword = \"s3cret\"\n",
            0o600,
        );
        let e = Credentials::read(&path).unwrap_err();
        assert!(e.contains("unknown field `pasword`"), "{e}");
        assert!(!e.contains("s3cret"), "{e}");
        let path = write(dir.path(), "username = \"ha\"\npassword = s3cret\n", 0o600);
        let e = Credentials::read(&path).unwrap_err();
        assert!(e.contains("(line 2)"), "{e}");
        assert!(!e.contains("s3cret"), "{e}");
        let e = Credentials::read(&dir.path().join("missing.toml")).unwrap_err();
        assert!(e.contains("missing.toml"), "{e}");
    }
}
