"""Running the system on this machine, for any command that starts parts of it: the web
server in a thread (``web_server``), free and taken ports (``ports``), one owner of Ctrl-C
and SIGTERM (``interrupts``), helper processes that die with their parent (``lifeline``)
and the demo's embedded server, worker and simulated face (``embedded``).

It sits below the commands (``chameleons.cli``) and the rehearsal (``chameleons.rehearsal``),
which both start a whole system, and above the server (``chameleons.backend``) it runs.
"""
