//! The command line's contract for bad input, shared by the CLI tests.

use std::path::Path;
use std::process::Output;

/// Bad input: exit status 2, exactly one line on stderr containing the scene
/// file's path and every string of `expect` (the key, the reason), no panic,
/// nothing on stdout, and no output folder `out` created.
pub fn assert_input_error(case: &str, o: &Output, scene: &Path, out: &Path, expect: &[&str]) {
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{case}: status {}, stderr {stderr}",
        o.status
    );
    assert!(!stderr.contains("panicked"), "{case}: {stderr}");
    assert!(stderr.ends_with('\n'), "{case}: {stderr:?}");
    let line = stderr.trim_end_matches('\n');
    assert!(
        !line.is_empty() && !line.contains('\n'),
        "{case}: not one line: {stderr:?}"
    );
    let path = scene.display().to_string();
    assert!(
        line.contains(&path),
        "{case}: no file path `{path}` in {line:?}"
    );
    for e in expect {
        assert!(line.contains(e), "{case}: no `{e}` in {line:?}");
    }
    assert!(
        o.stdout.is_empty(),
        "{case}: stdout {:?}",
        String::from_utf8_lossy(&o.stdout)
    );
    assert!(!out.exists(), "{case}: output folder was created");
}
