//! Every argument of every command has a description, and every command's `--help` ends with an
//! example: checked on clap's description of the command line, so a new argument or command
//! without them fails the tests.

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    fn walk(cmd: &clap::Command, path: &str, faults: &mut Vec<String>) {
        for arg in cmd.get_arguments() {
            let id = arg.get_id().as_str();
            if arg.is_hide_set() || id == "help" || id == "version" {
                continue;
            }
            let described = arg
                .get_help()
                .or(arg.get_long_help())
                .is_some_and(|h| !h.to_string().trim().is_empty());
            if !described {
                faults.push(format!("{path}: argument {id} has no description"));
            }
        }
        let after = cmd
            .get_after_help()
            .or(cmd.get_after_long_help())
            .map(|s| s.to_string())
            .unwrap_or_default();
        let last = after.trim_end().lines().last().unwrap_or("").trim();
        if !(after.contains("Example") && last.starts_with("demcal ")) {
            faults.push(format!(
                "{path}: --help does not end with an example (\"Example:\" and a demcal command line)"
            ));
        }
        for sub in cmd.get_subcommands() {
            if sub.get_name() != "help" {
                walk(sub, &format!("{path} {}", sub.get_name()), faults);
            }
        }
    }

    #[test]
    fn every_argument_is_described_and_every_help_ends_with_an_example() {
        let cmd = crate::Cli::command();
        let mut faults = Vec::new();
        walk(&cmd, "demcal", &mut faults);
        assert!(
            faults.is_empty(),
            "{} faults:\n{}",
            faults.len(),
            faults.join("\n")
        );
    }
}
