"""What importing a module brings with it: the metrics, the report and the plots need no simulator."""

import subprocess
import sys


def test_metrics_report_and_plots_import_no_simulator():
    code = ("import morphbench.bench.metrics, morphbench.bench.report, morphbench.bench.figures, "
            "morphbench.bench.claims, morphbench.plots, sys; "
            "assert 'pybullet' not in sys.modules and 'numba' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_a_package_name_is_the_function_even_after_its_submodule_was_imported():
    code = ("import morphbench.experiment.run, morphbench.experiment.scan; "
            "from morphbench.experiment import run, scan; assert callable(run) and callable(scan); "
            "assert run.__module__ == 'morphbench.experiment.run' and scan.__module__ == 'morphbench.experiment.scan'")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
