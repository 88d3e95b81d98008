//! Files the user names, read with a size limit checked before or while they are read, so that
//! a wrong path (`/dev/zero`, a 40 GB dump given as a scene) ends in one line instead of filling
//! the memory. The limits are far above any real file of each kind; `docs/reliability.md` lists
//! them.

use std::io::Read;
use std::path::Path;

/// Most bytes a TOML or JSON file (scene, test, study, job, summary) may have.
pub const MAX_TEXT_BYTES: u64 = 16 << 20;
/// Most bytes a CSV table (lab curves, designs with responses, sphere lists) may have.
pub const MAX_TABLE_BYTES: u64 = 256 << 20;
/// Most bytes an STL mesh may have (20 million triangles in binary).
pub const MAX_MESH_BYTES: u64 = 1 << 30;

/// `n` bytes as people read sizes.
fn size(n: u64) -> String {
    if n >= 1 << 30 {
        format!("{} GiB", n >> 30)
    } else {
        format!("{} MiB", n >> 20)
    }
}

/// The text of `path`, refused past `limit` bytes (read no further than one byte past it).
/// The error is the reason alone; callers put the file's name in front.
pub fn read_text(path: &Path, limit: u64) -> Result<String, String> {
    check_plain(path)?;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut bytes = Vec::new();
    file.take(limit + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| e.to_string())?;
    if bytes.len() as u64 > limit {
        return Err(format!(
            "larger than {}, the most such a file may be",
            size(limit)
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        format!(
            "not text: invalid UTF-8 at byte {}",
            e.utf8_error().valid_up_to()
        )
    })
}

/// Opens `path` for a reader that streams it (CSV, STL), after checking that it is a plain file
/// of at most `limit` bytes: a device or a pipe has no size to check, so it is refused.
pub fn open_checked(path: &Path, limit: u64) -> Result<std::fs::File, String> {
    check_plain(path)?;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let meta = file.metadata().map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err("not a plain file".to_string());
    }
    if meta.len() > limit {
        return Err(format!(
            "{} bytes, larger than {}, the most such a file may be",
            meta.len(),
            size(limit)
        ));
    }
    Ok(file)
}

/// Refuses anything but a plain file (or a link to one) before it is opened: opening a named
/// pipe waits for a writer, so the check must come first; a folder or a device has no text.
pub fn check_plain(path: &Path) -> Result<(), String> {
    let meta = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if meta.is_file() {
        return Ok(());
    }
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    let what = if t.is_dir() {
        "a folder"
    } else if t.is_fifo() {
        "a named pipe"
    } else if t.is_socket() {
        "a socket"
    } else {
        "a device"
    };
    Err(format!("not a plain file ({what})"))
}

/// Makes the output folder `dir` if need be and checks that a file can be written in it, so
/// that a read-only folder fails before a simulation of hours rather than after it.
pub fn check_writable(dir: &Path) -> Result<(), String> {
    std::fs::create_dir_all(dir)
        .map_err(|e| format!("{}: cannot make the folder: {e}", dir.display()))?;
    let probe = dir.join(format!(".demcal-write-check-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .map_err(|e| format!("{}: cannot write in this folder: {e}", dir.display()))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn endless_and_oversized_files_are_refused_without_reading_them_whole() {
        // A device is refused before it is opened (a named pipe would block the open).
        let e = read_text(Path::new("/dev/zero"), MAX_TEXT_BYTES).unwrap_err();
        assert_eq!(e, "not a plain file (a device)");
        assert_eq!(
            open_checked(Path::new("/dev/zero"), MAX_TABLE_BYTES).unwrap_err(),
            "not a plain file (a device)"
        );
        assert_eq!(
            read_text(Path::new("/tmp"), MAX_TEXT_BYTES).unwrap_err(),
            "not a plain file (a folder)"
        );
        let dir = std::env::temp_dir().join(format!("demcal-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("big.toml");
        std::fs::write(&p, vec![b'#'; 2048]).unwrap();
        assert_eq!(read_text(&p, 2048).unwrap().len(), 2048);
        assert!(read_text(&p, 2047).unwrap_err().starts_with("larger than"));
        assert!(open_checked(&p, 2047)
            .unwrap_err()
            .starts_with("2048 bytes, larger than"));
        std::fs::write(&p, [b'a', 0xff, b'b']).unwrap();
        assert_eq!(
            read_text(&p, 100).unwrap_err(),
            "not text: invalid UTF-8 at byte 1"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_folder_that_cannot_be_written_is_found_before_anything_runs() {
        use std::os::unix::fs::PermissionsExt;
        let dir = std::env::temp_dir().join(format!("demcal-ro-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        check_writable(&dir.join("out")).unwrap();
        assert!(dir.join("out").is_dir());
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o555)).unwrap();
        // root writes anywhere: then there is nothing to check.
        let root = std::fs::write(dir.join("x"), b"").is_ok();
        if !root {
            let e = check_writable(&dir.join("new")).unwrap_err();
            assert!(e.contains("cannot make the folder"), "{e}");
        }
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
