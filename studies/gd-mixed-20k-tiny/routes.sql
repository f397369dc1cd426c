-- Where the 20k players of each graph walked, against the 10k players of the same graph
-- (run on gd-mixed-20k's SQLite database: sqlite3 -header -column srg.db < routes.sql).
-- Graphs 1-3 baseline, 4-6 sr-heuristic, 7-9 sr-crowd, seeds 0, 1, 2; publication 3 is
-- the 10k checkpoint's (334 vertices), 4 the 20k one's (667).
select graph_id g, count(*) steps_20k, round(avg(err), 5) mean_err,
  round(1.0 * sum(edge_kind_name = 'blend') / count(*), 3) blend_share,
  round(1.0 * sum(vertex >= 334) / count(*), 3) on_vertices_grown_after_10k,
  round(1.0 * sum(edge_kind_name = 'blend' and vertex >= 334) / count(*), 3) on_their_blends
from analytics_steps where publication_number = 4 group by graph_id order by graph_id;

with t3 as (select distinct graph_id, vertex, control from analytics_steps
            where publication_number = 3),
e3 as (select pe.vertex, pe.control, pe.dst, pe.kind, p.graph_id from publication_edges pe
       join publications p on p.id = pe.publication_id and p.number = 3),
e4 as (select pe.vertex, pe.control, pe.dst, pe.kind, p.graph_id from publication_edges pe
       join publications p on p.id = pe.publication_id and p.number = 4),
s4 as (select graph_id, vertex, control from analytics_steps
       where publication_number = 4 and vertex < 334)
select s4.graph_id g, count(*) steps_on_old_vertices,
  round(1.0 * sum(e4.kind = 1) / count(*), 3) on_blends,
  round(1.0 * sum(e3.kind = 1) / count(*), 3) on_edges_blends_at_10k,
  round(1.0 * sum(e4.kind = 1 and e3.dst != e4.dst) / count(*), 3) on_relinked_blends,
  round(1.0 * sum(t3.vertex is not null) / count(*), 3) on_pairs_taken_at_10k
from s4
join e3 on e3.graph_id = s4.graph_id and e3.vertex = s4.vertex and e3.control = s4.control
join e4 on e4.graph_id = s4.graph_id and e4.vertex = s4.vertex and e4.control = s4.control
left join t3 on t3.graph_id = s4.graph_id and t3.vertex = s4.vertex and t3.control = s4.control
group by s4.graph_id order by s4.graph_id;
