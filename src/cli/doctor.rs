//! `sipnpuff doctor`: before the first start, what `run` with these
//! options would get here and be denied, each denial with its fix
//! ([`crate::session::doctor`]). Exit status 1 when something a deployed
//! controller needs is missing.

use crate::cli::args::{BackendArgs, ConfigArg, RtArgs};
use crate::cli::display::DisplayArgs;
use crate::cli::output;
use crate::session::doctor::{self, Check, Examined};

/// `doctor`'s options: `run`'s, so the same command line (or the
/// service's environment) is examined.
#[derive(clap::Args, Debug)]
pub struct DoctorArgs {
    #[command(flatten)]
    config: ConfigArg,
    #[command(flatten)]
    backends: BackendArgs,
    #[command(flatten)]
    display: DisplayArgs,
    #[command(flatten)]
    rt: RtArgs,
    /// Print one JSON object (the user and every check) instead of text.
    #[arg(long)]
    json: bool,
}

/// Runs every check and prints them; 0 when all that is needed is
/// granted, 1 otherwise.
pub fn doctor(args: DoctorArgs) -> anyhow::Result<u8> {
    let config = args.config.load()?;
    let examined = Examined {
        sensor: &args.backends.sensor,
        imu: args.backends.imu.as_ref(),
        arm: &args.backends.arm,
        outputs: &args.backends.outputs,
        rt: args.rt.options(config.rt())?,
        page: args.display.choice().page,
    };
    let checks = doctor::examine(&config, &examined);
    let user = user();
    let ready = doctor::all_needed_granted(&checks);
    if args.json {
        let json = serde_json::json!({ "user": user, "ready": ready, "checks": checks });
        output::stdout(&format!("{json}\n"))?;
    } else {
        output::stdout(&text(&user, &checks, ready))?;
    }
    Ok(if ready {
        output::COMPLETED
    } else {
        output::FAILED
    })
}

/// Who is asking: the user's name, uid and groups, as `id` prints them.
fn user() -> String {
    // SAFETY: getuid has no preconditions.
    let uid = unsafe { libc::getuid() };
    // SAFETY: getgid has no preconditions.
    let gid = unsafe { libc::getgid() };
    let mut groups = [0 as libc::gid_t; 64];
    // SAFETY: `groups` has room for the count passed.
    let n = unsafe { libc::getgroups(groups.len() as libc::c_int, groups.as_mut_ptr()) };
    let groups_file = std::fs::read_to_string("/etc/group").unwrap_or_default();
    let passwd = std::fs::read_to_string("/etc/passwd").unwrap_or_default();
    let name = name_of(&passwd, uid);
    let mut ids = vec![gid];
    for g in groups.iter().take(usize::try_from(n).unwrap_or(0)) {
        if !ids.contains(g) {
            ids.push(*g);
        }
    }
    let groups: Vec<String> = ids.into_iter().map(|g| name_of(&groups_file, g)).collect();
    format!("{name} (uid {uid}; groups: {})", groups.join(", "))
}

/// The name of `id` in an `/etc/passwd` or `/etc/group` text (`name:x:id:…`),
/// else the number.
fn name_of(file: &str, id: u32) -> String {
    let id = id.to_string();
    file.lines()
        .find_map(|l| {
            let mut fields = l.split(':');
            let name = fields.next()?;
            (fields.nth(1)? == id).then(|| name.to_string())
        })
        .unwrap_or(id)
}

/// The checks as lines: `ok`, `DENIED` (needed) or `missing` (optional),
/// each denial followed by its fix.
fn text(user: &str, checks: &[Check], ready: bool) -> String {
    let mut out = format!("sipnpuff doctor: what `sipnpuff run` would get here, as {user}\n");
    for c in checks {
        let mark = match (c.ok, c.needed) {
            (true, _) => "ok     ",
            (false, true) => "DENIED ",
            (false, false) => "missing",
        };
        out += &format!("  {mark} {}", c.what);
        if !c.detail.is_empty() {
            out += &format!(": {}", c.detail);
        }
        out += "\n";
        if let Some(fix) = &c.fix {
            out += &format!("          fix: {fix}\n");
        }
    }
    let denied = checks.iter().filter(|c| !c.ok && c.needed).count();
    out += &if ready {
        "all that a deployed controller needs is granted\n".to_string()
    } else {
        format!(
            "{denied} needed thing{} DENIED: fix {} before deploying\n",
            if denied == 1 { "" } else { "s" },
            if denied == 1 { "it" } else { "them" }
        )
    };
    out
}
