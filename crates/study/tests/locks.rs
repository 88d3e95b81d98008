//! The store's lock file: one runner per study, and a lock left malformed or stale (by a
//! crash, a copy, a reused process id) recognised and replaced safely (docs/reliability.md).

fn fresh_dir(name: &str) -> std::path::PathBuf {
    test_support::fresh_dir("study", name)
}

/// A lock file that is empty, garbage, a folder, or names a process id now used by another
/// program is recognised and replaced; one being written this moment, or a folder with files,
/// is not (issue 40: each of these blocked until removed by hand).
#[cfg(unix)]
#[test]
fn malformed_and_stale_locks_are_replaced_safely() {
    let dir = fresh_dir("lock-kinds");
    let db = dir.join("study.db");
    let lock_file = dir.join("study.db.lock");
    let age = |secs: u64| {
        let f = std::fs::File::options()
            .write(true)
            .open(&lock_file)
            .unwrap();
        f.set_modified(std::time::SystemTime::now() - std::time::Duration::from_secs(secs))
            .unwrap();
    };
    let take = || {
        let lock = study::store::StoreLock::acquire(&db).unwrap();
        let text = std::fs::read_to_string(&lock_file).unwrap();
        assert_eq!(
            text.lines().next(),
            Some(std::process::id().to_string().as_str())
        );
        // The start time is written with the id.
        assert!(
            text.lines().nth(2).unwrap().parse::<u64>().is_ok(),
            "{text}"
        );
        drop(lock);
        assert!(!lock_file.exists());
    };
    // Empty or garbage, and older than the few seconds a writer takes: replaced.
    for text in ["", "garbage\n", "\u{0}\u{0}"] {
        std::fs::write(&lock_file, text).unwrap();
        age(60);
        take();
    }
    // Empty this moment: its maker is writing it.
    std::fs::write(&lock_file, "").unwrap();
    let e = study::store::StoreLock::acquire(&db).unwrap_err();
    assert!(
        matches!(&e, study::LockError::Held(m) if m.contains("taking the study's lock this moment")),
        "{e:?}"
    );
    std::fs::remove_file(&lock_file).unwrap();
    // A live process that is not a demcal (an old lock without a start time), and one whose
    // start time differs from the lock's (its id reused): replaced.
    let mut sleeper = std::process::Command::new("sleep")
        .arg("30")
        .spawn()
        .unwrap();
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap();
    std::fs::write(&lock_file, format!("{}\n{}\n", sleeper.id(), host.trim())).unwrap();
    take();
    std::fs::write(
        &lock_file,
        format!("{}\n{}\n1\n", sleeper.id(), host.trim()),
    )
    .unwrap();
    take();
    sleeper.kill().unwrap();
    sleeper.wait().unwrap();
    // An empty folder where the lock belongs is removed; one with files is not ours.
    std::fs::create_dir(&lock_file).unwrap();
    take();
    std::fs::create_dir(&lock_file).unwrap();
    std::fs::write(lock_file.join("keep"), "x").unwrap();
    let e = study::store::StoreLock::acquire(&db).unwrap_err();
    assert!(
        matches!(&e, study::LockError::Io(m) if m.contains("is a folder with files in it")),
        "{e:?}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
