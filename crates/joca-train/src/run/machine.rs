//! The machine type a run's numbers came from, as `results.json`'s `cpu` names it.

/// The CPU's model name, its family and model numbers where the CPU reports them (Linux:
/// `/proc/cpuinfo`), and its widest vector units, for `results.json`.
///
/// The family and model are part of the machine type: libtorch's kernels pick their blocking
/// per microarchitecture, so two CPUs with the same model string and vector units (a Zen 4
/// and a Zen 5 EPYC) compute other floats and train other networks from one seed.
pub fn cpu_description() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    describe(&info, &joca_nn::kernels::vector_units())
}

/// [`cpu_description`] from the text of `/proc/cpuinfo` (its first processor) and the vector
/// units.
fn describe(cpuinfo: &str, units: &str) -> String {
    let field = |key: &str| {
        cpuinfo
            .lines()
            .take_while(|l| !l.trim().is_empty())
            .filter_map(|l| l.split_once(':'))
            .find(|(k, _)| k.trim() == key)
            .map(|(_, value)| value.trim().to_owned())
            .filter(|value| !value.is_empty())
    };
    let model = field("model name").unwrap_or_else(|| std::env::consts::ARCH.to_owned());
    match (field("cpu family"), field("model")) {
        (Some(family), Some(number)) => {
            format!("{model} (family {family} model {number}; {units})")
        }
        _ => format!("{model} ({units})"),
    }
}

#[cfg(test)]
mod tests {
    use super::describe;

    /// The head of `/proc/cpuinfo` of the 2-core EPYCs the project ran on (abridged).
    fn cpuinfo(family: u32, model: u32) -> String {
        format!(
            "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: {family}\nmodel\t\t: \
             {model}\nmodel name\t: AMD EPYC\nstepping\t: 1\n\nprocessor\t: 1\ncpu family\t: \
             99\nmodel\t\t: 99\n"
        )
    }

    #[test]
    fn two_microarchitectures_with_one_model_string_are_two_machine_types() {
        let units = "AVX-512, AVX-512 BF16";
        let zen4 = describe(&cpuinfo(25, 17), units);
        let zen5 = describe(&cpuinfo(26, 2), units);
        assert_eq!(zen4, "AMD EPYC (family 25 model 17; AVX-512, AVX-512 BF16)");
        assert_eq!(zen5, "AMD EPYC (family 26 model 2; AVX-512, AVX-512 BF16)");
        assert_eq!(
            describe(&cpuinfo(25, 1), "AVX2, FMA"),
            "AMD EPYC (family 25 model 1; AVX2, FMA)"
        );
    }

    #[test]
    fn a_cpu_without_family_numbers_is_named_by_model_and_units() {
        // An Arm `/proc/cpuinfo` has neither field (nor a model name on many boards).
        let arm = "processor\t: 0\nBogoMIPS\t: 50.00\nCPU implementer\t: 0x41\n";
        assert_eq!(describe(arm, "aarch64"), format!("{} (aarch64)", std::env::consts::ARCH));
        assert_eq!(describe("", "AVX2, FMA"), format!("{} (AVX2, FMA)", std::env::consts::ARCH));
        let no_model = "model name\t: Some CPU\ncpu family\t: 6\n";
        assert_eq!(describe(no_model, "AVX2, FMA"), "Some CPU (AVX2, FMA)");
    }
}
