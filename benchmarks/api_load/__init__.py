"""Load benchmark of the REST service: concurrent MES clients reporting parts (run on demand).

What it measures. For every configuration (backend x ``--workers``), on a fresh database:

1. the script starts its own ``rcb serve --db URL --workers N --no-access-log`` on 127.0.0.1
   and a free port (a SQLite file in a temporary directory, or a new PostgreSQL database
   ``rcb_bench_<random>`` dropped at the end); the API keys come from ``rcb keys create``;
2. it creates ``--plans K`` plans over the API (``POST /api/v1/plans``, engineer key) from
   ``examples/ivester_demo_part.toml``: all six operations, or only the first (``--ops 1``, one
   operation, i.e. a sixth of the measurements, band updates and LPs of a report);
3. ``--clients N`` client threads, each with its own keep-alive connection (the standard
   library's ``http.client``, lighter than httpx: the load generator shares the CPUs with the
   server) and the ``mes`` key, post part reports (``POST /api/v1/plans/{id}/parts`` with
   a unique ``Idempotency-Key`` and serial) back to back: a closed loop, each client sends its
   next report when the previous answer arrives. A report carries, as in the REST tests, the
   predicted value of every quantity at the setpoints the client last received for that plan
   (the creation answer, then each report's answer) with Table 5's uncertainties;
4. first ``--warmup`` seconds on separate warm-up plans (one per client, not counted): every
   worker that holds a connection loads its first plans and warms its caches there, so the
   measured plans start their learning in the window;
5. then the measured window of ``--duration`` seconds (the issue: 30 s), bounded too by
   ``--max-requests``. Counted: the reports *started* in the window; throughput = successful
   reports / (end of the last counted report - start of the window); latency = the client's
   wall time from sending the request to the whole answer read (HTTP, auth, the transaction
   with RCB and any re-solve, JSON), percentiles over the successful reports (p50/p95/p99,
   ``statistics.quantiles`` inclusive). Errors are counted by HTTP status or exception.

Plans and clients. A plan's reports are serialised by the database (row lock on the plan),
so one plan admits one report at a time. With ``--plans K >= --clients N`` client ``c`` owns
plans ``c, c+N, ...`` and cycles through them (no two clients share a plan); with ``K < N``
client ``c`` reports to plan ``c mod K`` and ``N/K`` clients contend for each plan (a report
made with a setpoint version another client has already superseded is applied at its own
version, which costs the server a few more queries for that version's setpoints).

Closed loop. Each client waits for its answer, so the reports in flight equal the clients
and, by Little's law, mean latency = clients / throughput (printed as "in flight"). The two
targets together therefore hold only at about 200 x 0.020 = 4 reports in flight or fewer: 16
clients at 200 reports/s wait 80 ms on average however fast each report is. Run a small
``--clients`` for the latency target and a larger one for the throughput ceiling.

Learning and converged reports. A report re-optimises the plan (six LPs, or one) only when
a band moves. With measurements equal to the predictions, each band shrinks by a quarter of
its margin per report until it reaches the measurement uncertainty: on the demonstration part
the first ~23 reports of a plan move a band and re-solve, later ones only hold (no LP). The
share of re-solving reports is printed ("re-solved"); more plans (``--plans``) give more
learning reports, fewer give a mostly converged shop.

CPU. Client and server share this machine's CPUs: the load generator is kept light (threads
blocked on sockets, one JSON body built per request), and the script prints the CPU seconds
used during the window (``/proc``) by the server's workers (per worker, with the keep-alive
connections each one accepted: one worker often takes most of them), by the PostgreSQL
backends of the benchmark database (those alive at the end of the window; the number of
sessions opened during the window is printed too), by the load generator itself, by other
processes and by the whole host, plus the CPU cost per report. Other work on the host skews
the figures: the summary's "other load" column is its share of the host's CPU during the
window, and ``--quiet-wait S`` waits up to S seconds for an idle host before each run.

Several workers and TCP_NODELAY. Every answer on a kept-alive connection goes out at once
(``GET /health`` about 1 ms with 2 workers): ``rcb serve`` binds the listener of several workers
itself as an ``IPPROTO_TCP`` socket (:mod:`api.rest.serving`, Kludex/uvicorn issue #3149), and
uvloop sets ``TCP_NODELAY`` on every TCP connection it accepts.

Targets from the issue (PostgreSQL, on this 2-core machine): p50 <= 20 ms and >= 200
reports/s; the script says for every PostgreSQL configuration whether they are met and exits
0 either way.

Usage (from the repository root)::

    .venv/bin/python -m benchmarks.api_load [--backend sqlite|postgres|both] [--workers 2,4]
        [--clients 16] [--plans K] [--ops 6|1] [--duration 30] [--warmup 3]
        [--max-requests 200000] [--postgres-url URL] [--quiet-wait S] [--markdown]

(``.venv/bin/python benchmarks/api_load ...`` runs the same.)

How long it takes: per configuration the duration and warm-up, plus about 15 s to create the
database, the keys and the plans and to start and stop the server (``--plans 400`` adds about
15 s more) and any ``--quiet-wait``; the default run (both backends x 2 worker counts) takes
about three and a half minutes.

Modules: :mod:`.cli` (options, the configurations in turn, the summary), :mod:`.run` (one
configuration and its figures), :mod:`.server` (benchmark database and ``rcb serve``),
:mod:`.clients` (plans and the MES clients' closed loop), :mod:`.cpu` (CPU accounting from
/proc), :mod:`.report` (what is printed), :mod:`.config` (paths and targets).
"""
